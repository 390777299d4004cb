"""Dataset containers: arrays, save/load, windows, meshes. Building them from the raw data
(catalog, splits, caching) is :mod:`data_prep`'s job; the library only reads what it is handed."""

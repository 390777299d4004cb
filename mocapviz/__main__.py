"""python -m mocapviz: the mocapviz command (:mod:`mocapviz.cli`)."""

from mocapviz.cli import main

if __name__ == "__main__":
    raise SystemExit(main())

"""python -m mocapviz: the mocapviz command (:mod:`mocapviz.cli`)."""

from mocapviz.cli import main

raise SystemExit(main())

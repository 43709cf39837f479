"""C sources and the linker script of the board images (:mod:`mwip.export.firmware`)."""

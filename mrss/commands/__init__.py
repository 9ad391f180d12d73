"""One module per `mrss` verb, each with `configure(parser)` and `run(args) -> int`."""

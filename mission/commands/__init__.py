"""One module per CLI verb; each exposes ``main(args: argparse.Namespace) -> int``."""

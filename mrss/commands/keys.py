"""`mrss keys PROJECT [--node NAME] [--force]`: make the CurveZMQ keypairs of a project's nodes.

Writes `NAME.secret` (owner-only, 0600) and `NAME.public` into the project's keys folder
(`[bus] keys_dir`, default `keys/`), for the node named, or for every declared node
without keys. The secret stays on its node; every other node needs the `.public` file.
Existing keys are kept unless `--force`. See docs/config.md, "[nodes]".
"""

from __future__ import annotations

import argparse
import sys

from mrss.bus.curve import generate, paths
from mrss.config.loader import load_project
from mrss.config.nodes import keys_dir, node_plan
from mrss.errors import ConfigError

EXIT_CONFIG = 2


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("project", help="project name (projects/<name>/)")
    parser.add_argument("--node", default=None,
                        help="the node to make keys for (default: every node without keys)")
    parser.add_argument("--force", action="store_true", help="replace existing keys")


def run(args: argparse.Namespace) -> int:
    try:
        config = load_project(args.project)
        plan = node_plan(config)
        if not plan.multi:
            raise ConfigError("the project declares no [nodes]: one host needs no keys",
                              file=str(config.file), key="nodes")
        folder = keys_dir(config)
        if args.node:
            names = [plan.check_node(args.node).name]
        else:
            names = [n for n in plan.nodes if not paths(folder, n)[1].exists()]
        for name in names:
            public, secret = generate(folder, name, force=args.force)
            print(f"node {name}: {secret} (keep it on {name} only), {public} (copy it to "
                  "every other node)")
        if not names:
            print(f"every node has keys in {folder} (--node NAME --force replaces one)")
    except ConfigError as exc:
        print(f"mrss keys: {exc}", file=sys.stderr)
        return EXIT_CONFIG
    return 0

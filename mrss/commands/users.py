"""`mrss users PROJECT add|remove|list|set-role`: the operators of a project.

    mrss users wildfire add alice --role commander            # asks for a password
    mrss users wildfire add bob --role observer --token       # prints a token, once
    mrss users wildfire set-role bob operator
    mrss users wildfire list
    mrss users wildfire remove bob

The store is `secrets/operators.json` in the project folder (mrss/auth/store.py): made
by the first `add`, private to its owner (0600; a more open file is refused). A
password is read from the terminal (twice) or from stdin's first line; `--token` makes
a personal token instead (or as well) and prints it once. `--expires-days N` ends the
identity N days from now. Exits 2 on a mistake, saying which.
"""

from __future__ import annotations

import argparse
import getpass
import sys
import time

from mrss.auth.roles import Role
from mrss.auth.store import OperatorStore, new_token, store_path
from mrss.config.projects import project_path
from mrss.errors import ConfigError, UnknownProjectError

EXIT_USAGE = 2


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("project", help="project name (projects/<name>/)")
    verbs = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    add = verbs.add_parser("add", help="add an operator, or give one a new secret")
    add.add_argument("name")
    add.add_argument("--role", required=True, choices=[r.value for r in Role])
    add.add_argument("--token", action="store_true",
                     help="make a personal token (printed once) instead of a password")
    add.add_argument("--expires-days", type=float, default=None, metavar="N",
                     help="the identity ends N days from now (default: never)")
    remove = verbs.add_parser("remove", help="remove an operator")
    remove.add_argument("name")
    verbs.add_parser("list", help="list the operators and their roles")
    role = verbs.add_parser("set-role", help="change an operator's role")
    role.add_argument("name")
    role.add_argument("role", choices=[r.value for r in Role])


def run(args: argparse.Namespace) -> int:
    try:
        path = store_path(project_path(args.project))
        exists = path.exists()
        if args.action != "add" and not exists:
            print(f"mrss users: {args.project} has no users yet ({path} does not exist); "
                  f"add one with mrss users {args.project} add NAME --role commander",
                  file=sys.stderr)
            return EXIT_USAGE
        store = OperatorStore.load(path) if exists else OperatorStore.new(path)
        if args.action == "list":
            for user in sorted(store.users.values(), key=lambda u: u.name):
                kinds = [k for k, v in (("password", user.password), ("token", user.token))
                         if v]
                ends = (time.strftime(" expires %Y-%m-%d %H:%M", time.localtime(user.expires))
                        + (" (expired)" if user.expired() else "")) if user.expires else ""
                print(f"{user.name}  {user.role.value}  {'+'.join(kinds) or 'no secret'}"
                      f"{ends}")
            return 0
        if args.action == "remove":
            store = store.without_user(args.name)
            store.save()
            print(f"removed {args.name}")
            return 0
        if args.action == "set-role":
            if args.name not in store.users:
                store.without_user(args.name)  # says "no user ... did you mean"
            store = store.with_user(args.name, Role(args.role))
            store.save()
            print(f"{args.name} is now {args.role}")
            return 0
        expires = time.time() + args.expires_days * 86400 if args.expires_days else None
        if args.token:
            token = new_token()
            store = store.with_user(args.name, Role(args.role), token=token, expires=expires)
        else:
            token = ""
            store = store.with_user(args.name, Role(args.role), password=_password(args.name),
                                    expires=expires)
        store.save()
        print(f"{args.name} ({args.role}) in {path}")
        if token:
            print(f"token (shown once, keep it secret): {token}")
        return 0
    except (ConfigError, UnknownProjectError, ValueError, OSError) as exc:
        print(f"mrss users: {exc}", file=sys.stderr)
        return EXIT_USAGE


def _password(name: str) -> str:
    if not sys.stdin.isatty():
        return sys.stdin.readline().rstrip("\n")
    first = getpass.getpass(f"password for {name}: ")
    if getpass.getpass("again: ") != first:
        raise ValueError("the two passwords differ")
    return first

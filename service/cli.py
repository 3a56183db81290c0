"""The ``depot`` command line: serve, migrate, users, demo, replay, and each part's tools."""

from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
import sys
import warnings
from collections.abc import Sequence
from datetime import datetime

from pydantic import ValidationError
from sqlalchemy.engine import make_url
from sqlalchemy.exc import (
    ArgumentError,
    IntegrityError,
    NoSuchModuleError,
    OperationalError,
    ProgrammingError,
    SQLAlchemyError,
)

from core.database import get_engine, get_sessionmaker, utcnow
from core.errors import DepotError
from core.settings import get_settings
from service import commands
from service.commands._common import DepotParser, fail, number

PORT = number(int, low=1, high=65535)
WORKERS = number(int, low=1, high=64)
LIFETIME = number(low=0, high=3650, low_open=True)  # days, as the API's expires_in_days


# The databases depot runs on (backend, SQLAlchemy driver); anything else has no driver
# installed, or no tested schema, and must be refused with the fix, not with a traceback.
DATABASES = (("sqlite", "pysqlite"), ("postgresql", "psycopg"))
DATABASE_FIX = "use postgresql+psycopg://USER@HOST/DB, or unset it for SQLite under DEPOT_DATA_DIR"


class UnsupportedDatabase(Exception):
    """The configured database is not one depot runs on (the message says which and why)."""


def database_problem() -> str | None:
    """Why the configured database cannot be used, in words, when its URL names a database
    (or driver) depot does not support; None when it is supported or not a URL at all (a
    URL that does not parse is reported where it is used)."""
    url = get_settings().resolved_database_url
    try:
        parsed = make_url(url)
        kind = (parsed.get_backend_name(), parsed.get_driver_name())
    except (ArgumentError, NoSuchModuleError):
        return None
    if kind in DATABASES:
        return None
    return (
        f"the database cannot be used: DEPOT_DATABASE_URL names {kind[0]} (driver {kind[1]}),"
        f" which is not supported; {DATABASE_FIX}"
    )


def migration_problem() -> str | None:
    """Why a reachable database cannot be used when it was never migrated (its tables are
    missing: SQLite says OperationalError, PostgreSQL ProgrammingError); None when it has a
    schema or cannot even be reached (reported by the caller)."""
    from service.migrate import current_revision

    try:
        with get_engine().connect() as connection:
            revision = current_revision(connection)
    except SQLAlchemyError:
        return None
    if revision is not None:
        return None
    return "the database is not migrated (it has no depot schema yet); run `depot migrate` first"


def _usable_database() -> None:
    """Stop before a server or a migration starts on a database depot does not support."""
    problem = database_problem()
    if problem is not None:
        raise UnsupportedDatabase(problem)


def _serve(args: argparse.Namespace) -> int:
    import uvicorn

    from service.header_deadline import HeaderDeadlineProtocol

    _usable_database()
    settings = get_settings()
    if args.migrate:
        _migrate(args)
    uvicorn.run(
        "service.app:create_app",
        factory=True,
        host=args.host or settings.host,
        port=args.port or settings.port,
        workers=args.workers,
        log_level="info",
        access_log=settings.access_log,
        # The app reads X-Forwarded-* itself, from DEPOT_TRUSTED_PROXIES only.
        proxy_headers=False,
        # uvicorn kills a worker that answers no health ping for this long; its default (5 s)
        # is shorter than a worker's start on a busy 2-core host, which then never comes up.
        timeout_worker_healthcheck=60,
        # Connections that never finish their headers are closed (DEPOT_HEADER_TIMEOUT_S).
        http=HeaderDeadlineProtocol,
    )
    return 0


def _migrate(_: argparse.Namespace) -> int:
    from service.migrate import upgrade

    _usable_database()
    settings = get_settings()
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    upgrade(settings.resolved_database_url)
    print(f"database at head: {settings.resolved_database_url.split('@')[-1]}")
    return 0


def _user_add(args: argparse.Namespace) -> int:
    from service.setup.credentials import add_user, find_person

    with get_sessionmaker().begin() as session:
        back = find_person(session, args.name) is not None  # revoked, else add_user refuses
        user, token = add_user(
            session, args.name, args.role, actor="cli", expires_in_days=args.expires_in_days
        )
        name = user.name
    done = "added again (had been revoked)" if back else "created"
    print(f"user {name} ({args.role}) {done}. Token (shown once, store it now):")
    print(token)
    return 0


def _user_list(_: argparse.Namespace) -> int:
    from service.setup.credentials import list_users

    with get_sessionmaker().begin() as session:
        users = list_users(session)
        print(f"{'name':24s} {'role':11s} {'created (UTC)':17s} {'expires':17s} state")
        for u in users:
            expired = u.expires_at is not None and u.expires_at <= utcnow()
            state = "revoked" if u.revoked_at else "expired" if expired else "active"
            print(
                f"{u.name:24s} {u.role:11s} {_minute(u.created_at):17s}"
                f" {_minute(u.expires_at) or 'never':17s} {state}"
            )
    return 0


def _minute(at: datetime | None) -> str:
    return "" if at is None else at.strftime("%Y-%m-%d %H:%M")


def _user_rotate(args: argparse.Namespace) -> int:
    from service.setup.credentials import rotate_user

    with get_sessionmaker().begin() as session:
        _, token = rotate_user(
            session, args.name, actor="cli", expires_in_days=args.expires_in_days
        )
    print(f"new token for {args.name} (shown once; the old one stops working now):")
    print(token)
    return 0


def _device_key(args: argparse.Namespace) -> int:
    from service.setup.credentials import rotate_device_key

    with get_sessionmaker().begin() as session:
        _, key = rotate_device_key(session, args.device, actor="cli")
    print(f"new key for device {args.device} (shown once; the old one stops working now):")
    print(key)
    return 0


def _device_decommission(args: argparse.Namespace) -> int:
    from service.setup.credentials import decommission_device

    with get_sessionmaker().begin() as session:
        decommission_device(session, args.device, actor="cli")
    print(f"device {args.device} decommissioned: its events are refused; its history stays")
    return 0


def _user_revoke(args: argparse.Namespace) -> int:
    from service.setup.credentials import revoke_user

    with get_sessionmaker().begin() as session:
        revoke_user(session, args.name, actor="cli")
    print(f"user {args.name} revoked: their token stops working now")
    return 0


def _replay(_: argparse.Namespace) -> int:
    from service import features
    from service.replay import replay

    features.install()
    with get_sessionmaker().begin() as session:
        counts = replay(session)
    print(
        f"replayed {counts['events']} raw events ({counts['failed']} failed to derive),"
        f" re-applied {counts['actions']} dispatcher actions"
        f" ({counts['refused_actions']} no longer apply)"
    )
    return 0 if counts["failed"] == 0 else 1


def _demo(args: argparse.Namespace) -> int:
    with warnings.catch_warnings():
        # Starlette's note on its test client's transport (the demo posts through it):
        # nothing a person running the demo can act on.
        warnings.filterwarnings("ignore", message="Using `httpx` with `starlette.testclient`")
        from service.demo import load_demo

    return load_demo(force=args.force)


def build_parser() -> argparse.ArgumentParser:
    parser = DepotParser(prog="depot", description="Railway depot and operations service.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    serve = sub.add_parser("serve", help="serve the HTTP API and the review screen")
    serve.add_argument("--host", help="address to listen on (default: DEPOT_HOST, 127.0.0.1)")
    serve.add_argument(
        "--port", type=PORT, help="TCP port to listen on (default: DEPOT_PORT, 8000)"
    )
    serve.add_argument("--workers", type=WORKERS, default=1, help="worker processes (1 to 64)")
    serve.add_argument("--migrate", action="store_true", help="migrate the database first")
    serve.set_defaults(func=_serve)
    sub.add_parser(
        "migrate", help="bring the database schema to the latest migration"
    ).set_defaults(func=_migrate)
    user_parser = sub.add_parser("user", help="manage people's tokens")
    user_parser.set_defaults(action_group=user_parser)
    user = user_parser.add_subparsers(dest="user_command", metavar="ACTION")
    add = user.add_parser("add", help="add a person; prints their token once")
    add.add_argument(
        "name",
        help="what the person is called, any alphabet (Олена Коваль): letters, digits, single"
        " spaces, '-', '.', '_', apostrophes (≤ 64)",
    )
    add.add_argument(
        "--role", required=True, choices=("dispatcher", "engineer"), help="what they may do"
    )
    add.add_argument(
        "--expires-in-days",
        type=LIFETIME,
        default=None,
        help="token lifetime, days (default: no expiry)",
    )
    add.set_defaults(func=_user_add)
    user.add_parser("list", help="list people, their roles and token state").set_defaults(
        func=_user_list
    )
    rotate = user.add_parser("rotate", help="a new token for NAME (prints it once)")
    rotate.add_argument("name", help="the person whose token is replaced")
    rotate.add_argument(
        "--expires-in-days",
        type=LIFETIME,
        default=None,
        help="new token lifetime, days (default: the old token's expiry)",
    )
    rotate.set_defaults(func=_user_rotate)
    revoke = user.add_parser("revoke", help="NAME's token stops working at once")
    revoke.add_argument("name", help="the person whose token stops working")
    revoke.set_defaults(func=_user_revoke)
    device = sub.add_parser("device", help="rotate a device key or decommission a device")
    device.set_defaults(action_group=device)
    device_sub = device.add_subparsers(dest="device_command", metavar="ACTION")
    for action, func, text in (
        ("key", _device_key, "a new key for DEVICE (prints it once; the old one stops)"),
        ("decommission", _device_decommission, "refuse DEVICE's events from now on"),
    ):
        parser_ = device_sub.add_parser(action, help=text)
        parser_.add_argument("device", help="the device id, as registered")
        parser_.set_defaults(func=func)
    demo = sub.add_parser("demo", help="load the demo line and a simulated day of traffic")
    demo.add_argument("--force", action="store_true", help="load even if data is already there")
    demo.set_defaults(func=_demo)
    sub.add_parser("replay", help="rebuild derived tables from the raw events").set_defaults(
        func=_replay
    )
    for module in pkgutil.iter_modules(commands.__path__):
        if module.name.startswith("_"):
            continue  # helpers of the command modules, not commands
        importlib.import_module(f"service.commands.{module.name}").register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not hasattr(args, "func"):
        group = getattr(args, "action_group", None)
        if group is not None:
            return _missing_action(group)
        parser.print_help()
        return 2
    try:
        return int(args.func(args))
    except BrokenPipeError:
        return _reader_gone()
    except UnsupportedDatabase as exc:
        return fail(str(exc))
    except DepotError as exc:
        return fail(exc.detail)
    except IntegrityError as exc:
        return fail(f"the database refused the change ({exc.orig})")
    except ValidationError as exc:
        if exc.title != "Settings":
            raise
        return fail(settings_problem(exc))
    except (
        OperationalError,
        ProgrammingError,
        NoSuchModuleError,
        ArgumentError,
        ImportError,
    ) as exc:
        # an unsupported URL fails wherever its engine is made (no driver: ImportError)
        problem = database_problem() or migration_problem()
        if problem is not None:
            return fail(problem)
        if isinstance(exc, ImportError | ProgrammingError):
            raise
        first = str(getattr(exc, "orig", None) or exc).strip().splitlines()[0]
        return fail(
            f"the database cannot be used ({first}); check DEPOT_DATABASE_URL"
            " (postgresql+psycopg://USER@HOST/DB, or unset for SQLite under DEPOT_DATA_DIR)"
            " and that it is migrated (depot migrate)"
        )


SIGPIPE_EXIT = 141
"""Exit code of a command whose reader closed the pipe (128 + SIGPIPE, as shells report)."""


def _reader_gone() -> int:
    """``depot ... | head``: the reader has stopped; end quietly. Standard output goes to
    the null device so that the interpreter's final flush cannot fail again."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    return SIGPIPE_EXIT


def _missing_action(group: argparse.ArgumentParser) -> int:
    """``depot user`` alone: that command's help (not the top level's) and what is missing."""
    group.print_help(sys.stderr)
    actions = [
        name
        for action in group._actions
        if isinstance(action, argparse._SubParsersAction)
        for name in action.choices
    ]
    command = group.prog.removeprefix("depot").strip()
    return fail(f"{command}: name an ACTION: {', '.join(actions)}")


def settings_problem(exc: ValidationError) -> str:
    """The settings' errors in words, never with the values given: a pydantic message quotes
    its input, and the input of the settings holds the admin and metrics tokens."""
    lines = []
    for error in exc.errors(include_input=False, include_url=False):
        message = error["msg"].removeprefix("Value error, ")
        field = "_".join(str(part) for part in error["loc"]).upper()
        lines.append(f"DEPOT_{field}: {message}" if field else message)
    return "invalid settings: " + "; ".join(lines)


if __name__ == "__main__":
    sys.exit(main())

"""CLI command of the EOT radio decoder: ``depot eot-decode FILE.wav [--json]``.

Registered into ``depot`` by ``service.cli`` through :func:`register`.
"""

from __future__ import annotations

import argparse
import json

from identification.eot import decode_wav
from service.commands._common import fail

__all__ = ["register"]

_BATTERY = {3: "OK", 2: "low", 1: "very low", 0: "not monitored"}


def _eot_decode(args: argparse.Namespace) -> int:
    try:
        packets = decode_wav(args.file)
    except ValueError as exc:
        return fail(f"{exc}; give an FM-demodulated recording as PCM WAV (8 kHz or more)")
    for p in packets:
        if args.json:
            print(json.dumps(p.to_dict()))
        else:
            print(
                f"{p.at_s:7.3f} s  unit {p.unit_address:6d}  {p.pressure_psig:3d} psig"
                f"  battery {p.battery_charge}/127 ({_BATTERY[p.battery_condition]})"
                f"  motion {'yes' if p.motion else 'no'}"
                f"  marker light {'on' if p.marker_light else 'off'}"
            )
    if not packets and not args.json:
        print(f"{args.file}: no valid EOT packet")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Add ``eot-decode`` to ``depot``'s sub-command parser."""
    p = subparsers.add_parser(
        "eot-decode", help="decode end-of-train radio packets from a WAV recording"
    )
    p.add_argument("file", metavar="FILE.wav", help="FM-demodulated audio, PCM WAV")
    p.add_argument("--json", action="store_true", help="one JSON object per packet")
    p.set_defaults(func=_eot_decode)

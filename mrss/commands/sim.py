"""`mrss sim uav|ugv|fleet ...`: run a simulated robot (or a fleet of them) as a process."""

from __future__ import annotations

import argparse

from mrss.sim import fleet, uav, ugv

ROBOTS = {"uav": uav, "ugv": ugv, "fleet": fleet}


def configure(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="robot", metavar="{uav,ugv,fleet}", required=True)
    sub.add_parser("uav", help="MAVLink quadcopter answering like ArduCopter",
                   description=uav.__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub.add_parser("ugv", help="MQTT ground vehicle with a water tank",
                   description=ugv.__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub.add_parser("fleet", help="many UAVs and UGVs in one process (one event loop)",
                   description=fleet.__doc__,
                   formatter_class=argparse.RawDescriptionHelpFormatter)
    for name, module in ROBOTS.items():
        module.configure(sub.choices[name])


def run(args: argparse.Namespace) -> int:
    result: int = ROBOTS[args.robot].run(args)
    return result

r"""The operator's console for a running wildfire system (a stand-in for the UI of paper VI).

    python projects/wildfire/operator_console.py area a1 --center=-35.360567,149.165237 \
        --radius 100 -p 2
    python projects/wildfire/operator_console.py area a2 \
        --polygon="-35.36,149.16;-35.36,149.17;-35.37,149.16"
    python projects/wildfire/operator_console.py priority a2 5
    python projects/wildfire/operator_console.py cancel a1
    python projects/wildfire/operator_console.py teleop ugv1 on        # ... off
    python projects/wildfire/operator_console.py status                 # robots, areas, hotspots

It publishes the JSON events of events.py on the system's MQTT broker, sending each
again (same id) until the events manager answers it, prints the answer (accepted,
rejected or failed, with the reason; exit 1 unless accepted), and reads the world model
over its HTTP API. Both addresses come from the run folder (`--run-dir`,
default: the newest /tmp/mrss-wildfire-* that has a broker.url) or `--broker URL`.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path
from typing import Any

from mrss.api import (
    BROKER_URL_FILE,
    MrssError,
    WorldModelClient,
    request_json,
    world_model_token,
)

TOPIC_PREFIX = "mrss/ui"


def newest_run_dir() -> Path | None:
    """The most recent run folder of `mrss supervise wildfire` without --run-dir."""
    runs = [p for p in Path(tempfile.gettempdir()).glob("mrss-wildfire-*")
            if (p / BROKER_URL_FILE).is_file()]
    return max(runs, key=lambda p: p.stat().st_mtime) if runs else None


def point(text: str) -> list[float]:
    lat, lon = (float(v) for v in text.split(","))
    return [lat, lon]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="operator_console.py", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--run-dir", type=Path, default=None, help="the system's run folder")
    parser.add_argument("--broker", default=None, help="MQTT broker URL (default: run folder)")
    parser.add_argument("--patience", type=float, default=30.0,
                        help="seconds to keep sending until the system answers (default 30)")
    sub = parser.add_subparsers(dest="command", required=True)
    area = sub.add_parser("area", help="send an area to cover")
    area.add_argument("goal")
    area.add_argument("-p", "--priority", type=int, default=1)
    area.add_argument("--center", type=point, help="LAT,LON (write --center=LAT,LON)")
    area.add_argument("--radius", type=float, default=100.0, help="metres (with --center)")
    area.add_argument("--polygon", help="LAT,LON;LAT,LON;... (write --polygon=...)")
    cancel = sub.add_parser("cancel", help="cancel a goal")
    cancel.add_argument("goal")
    prio = sub.add_parser("priority", help="change a goal's priority")
    prio.add_argument("goal")
    prio.add_argument("priority", type=int)
    teleop = sub.add_parser("teleop", help="switch a robot to teleoperation and back")
    teleop.add_argument("robot")
    teleop.add_argument("state", choices=("on", "off"))
    sub.add_parser("status", help="print the world model: robots, areas, hotspots")
    return parser


def message(args: argparse.Namespace) -> tuple[str, dict[str, Any]]:
    """The topic and payload of a command."""
    if args.command == "area":
        payload: dict[str, Any] = {"goal": args.goal, "priority": args.priority}
        if args.polygon:
            payload["polygon"] = [point(p) for p in args.polygon.split(";") if p.strip()]
        elif args.center:
            payload.update(center=args.center, radius=args.radius)
        else:
            raise SystemExit("operator_console.py area: give --center=LAT,LON or --polygon=...")
        return f"{TOPIC_PREFIX}/area", payload
    if args.command == "cancel":
        return f"{TOPIC_PREFIX}/cancel", {"goal": args.goal}
    if args.command == "priority":
        return f"{TOPIC_PREFIX}/priority", {"goal": args.goal, "priority": args.priority}
    return f"{TOPIC_PREFIX}/teleop", {"robot": args.robot, "on": args.state == "on"}


def status(run_dir: Path) -> None:
    # The project's world model token ([worldmodel] token_file), if it sets one.
    client = WorldModelClient(run_dir=run_dir, timeout=5,
                              token=world_model_token(Path(__file__).resolve().parent))
    objects = client.objects()
    for obj in sorted(objects, key=lambda o: (o["kind"], o["id"])):
        pos = obj.get("position") or {}
        where = f"{pos['lat']:.6f},{pos['lon']:.6f}" if pos else "-"
        print(f"{obj['kind']:<13} {obj['id']:<10} {where:<24} {json.dumps(obj['attributes'])}")


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    run_dir = args.run_dir or newest_run_dir()
    if args.command == "status":
        if run_dir is None:
            print("operator_console.py: no run folder found; give --run-dir", file=sys.stderr)
            return 2
        status(run_dir)
        return 0
    broker = args.broker
    if broker is None:
        if run_dir is None or not (run_dir / BROKER_URL_FILE).is_file():
            print("operator_console.py: no broker.url found; give --run-dir or --broker",
                  file=sys.stderr)
            return 2
        broker = (run_dir / BROKER_URL_FILE).read_text(encoding="utf-8").strip()
    topic, payload = message(args)
    try:  # sent again until the events manager answers (project.toml: reply_accepted)
        answer = request_json(broker, topic, payload, client_id="mrss-operator",
                              patience=args.patience)
    except MrssError as exc:
        print(f"operator_console.py: {exc}", file=sys.stderr)
        return 1
    outcome = str(answer.get("status", "?"))
    reason = f": {answer['reason']}" if answer.get("reason") else ""
    print(f"{topic} {json.dumps(payload)} -> {outcome}{reason}")
    return 0 if outcome in ("accepted", "duplicate") else 1


if __name__ == "__main__":
    sys.exit(main())

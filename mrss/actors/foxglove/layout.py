"""The Foxglove layout for an MRSS system: the map, the plots, the messages worth watching.

`mission_layout(robots)` builds it with the Foxglove SDK's layout types for the given
robot ids; docs/foxglove-layout.json is the one for wildfire's robots (a test keeps the
file equal to what this builds). Every topic it names is a channel of the recording and
of the live component (`bridge.py`): the robots' `robot.<id>.location` on the Map panel;
from their `robot.<id>.data` records the battery, the altitude above home and the tank
level as plots; action statuses, percepts and the reasoner's log as raw messages.

Topics with dots are quoted in message paths (Foxglove's syntax); a record type is
picked with a filter, e.g. `"robot.ugv1.data".body.data{type=="tank"}.level`.
"""

from __future__ import annotations

from collections.abc import Sequence

import foxglove.layouts as fl

from mrss.recording.mcap_writer import LOCATION_SUFFIX

# (title, record type, field): the plots, one series a robot
PLOTS = (("Battery %", "battery", "remaining"),
         ("Altitude above home (m)", "position", "relative_alt"),
         ("Tank (l)", "tank", "level"))
WATCHED = ("action.status", "percept", "log.reasoner")  # raw messages of these topics


def data_path(robot: str, record: str, field: str) -> str:
    """The message path of one field of a robot's telemetry records of one type."""
    return f'"robot.{robot}.data".body.data{{type=="{record}"}}.{field}'


def mission_layout(robots: Sequence[str]) -> fl.Layout:
    """The layout for a system with these robots."""
    locations = [f"robot.{robot}{LOCATION_SUFFIX}" for robot in robots]
    map_panel = fl.MapPanel(title="Robots", config=fl.MapConfig(
        layer="map", follow_topic=locations[0] if locations else None))
    plots = [fl.SplitItem(content=fl.PlotPanel(title=title, config=fl.PlotConfig(
        paths=[fl.PlotSeries(value=data_path(robot, record, field), label=robot)
               for robot in robots], show_legend=True)))
             for title, record, field in PLOTS]
    raw = [fl.SplitItem(content=fl.RawMessagesPanel(
        title=topic, config=fl.RawMessagesConfig(topic_path=f'"{topic}"'
                                                 if "." in topic else topic)))
           for topic in WATCHED]
    return fl.Layout(content=fl.SplitContainer(direction="column", items=[
        fl.SplitItem(proportion=2, content=fl.SplitContainer(direction="row", items=[
            fl.SplitItem(proportion=2, content=map_panel),
            fl.SplitItem(proportion=1, content=fl.SplitContainer(direction="column",
                                                                 items=plots)),
        ])),
        fl.SplitItem(proportion=1, content=fl.SplitContainer(direction="row", items=raw)),
    ]))

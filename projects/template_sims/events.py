"""External adapter: outside events -> percepts (see the template's events.py for more).

ADAPT: the operator's messages. `mrss/ui/goto` `{"goal": "g1", "robot": "ugv1", "lat":
48.2, "lon": 16.37}` -> `goto_received(g1, ugv1, 48.2, 16.37)`; `mrss/ui/cancel`
`{"goal": "g1"}` -> `goal_cancelled(g1)`; `mrss/ui/survey` `{"goal": "s1", "lat": 48.2,
"lon": 16.37}` -> `survey_received(s1, 48.2, 16.37)`, a goal for whichever robot with a
camera is best placed (the agent addresses it to a role). A payload that does not fit
(a robot the RCL does not have, too) is reported back on `<topic>/reply`, never a
percept.
"""

from __future__ import annotations

from mrss.api import ExternalAdapter, Field, JsonMapping, Option

GOTO = JsonMapping("goto_received", Field("goal", "atom"), Field("robot", "robot"),
                   Field("lat", "lat"), Field("lon", "lon"))
CANCEL = JsonMapping("goal_cancelled", Field("goal", "atom"))
SURVEY = JsonMapping("survey_received", Field("goal", "atom"), Field("lat", "lat"),
                     Field("lon", "lon"))


class ProjectEvents(ExternalAdapter):
    """ADAPT: the project's external adapter (exactly one ExternalAdapter subclass here)."""

    OPTIONS = (Option("topic_prefix", str, "mrss/ui", "prefix of the UI's topics"),)

    def start(self) -> None:
        prefix = str(self.options.get("topic_prefix", "mrss/ui")).rstrip("/")
        self.map_json(f"{prefix}/goto", GOTO)
        self.map_json(f"{prefix}/cancel", CANCEL)
        self.map_json(f"{prefix}/survey", SURVEY)

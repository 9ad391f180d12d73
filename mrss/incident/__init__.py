"""The incident record: what happened to the mission, kept by the system in the run dir
(`incident.jsonl`), shown to a dashboard that attaches late, exported as a report."""

"""`mrss chaos PROJECT`: fault campaigns against a real system, and a checker of its history.

- `faults`: the fault kinds and how each is injected into a running system;
- `campaign`: the seeded schedule of faults;
- `traffic`: the operator traffic a project declares (`projects/<name>/chaos.py`);
- `history`: the records of a campaign and their JSON-lines file;
- `recorder`: records the bus, the operator's replies, probes, the journal and the log;
- `checker`: the invariants, pure functions over a history;
- `report`: the text a person reads;
- `runner`: runs one campaign end to end.
"""

"""Tasks addressed to a role: which robot takes each, decided by the robots' own bids.

One module per idea: `task` (what a role-addressed request asks for), `profile` (what a
robot declares it can do, from its project.toml table), `bids` (a robot's bid from its
own state), `evaluators` (how bids are ranked, and the deterministic tie-break),
`allocator` (the open tasks, the rounds of bidding, the award).
"""

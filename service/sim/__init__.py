"""Simulations in worker processes: :mod:`.pool` (start, hand out, kill), :mod:`.worker` (the process itself),
:mod:`.job` (what travels between them)."""

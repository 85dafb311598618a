"""Missions: ordered steps (goals, waits, pauses, approaches) run through the planner."""

"""``navd fleet``: a small fleet control that drives navd vehicles over VDA 5050 (a separate
process, never inside a robot)."""

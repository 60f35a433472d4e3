"""The high-level tactical planner: the paper's discrete racing game (section 4.1) and its solvers."""

"""Linear-quadratic games: the feedback Nash solver and the LQNG waypoint tracker (paper section 4.2.3)."""

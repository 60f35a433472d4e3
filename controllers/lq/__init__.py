"""Linear-quadratic games (paper section 4.2.3): the feedback Nash solver (``nash``), the LQNG game's dynamics
and cost terms (``game``) and the LQNG waypoint tracker with its tuned presets (``tracker``)."""

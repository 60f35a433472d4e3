"""Layout of the batched world state: named column indices into the packed arrays.

Per kart (arrays of shape (B, K, ...)): floats ``F_*`` in ``fstate`` and integers ``I_*`` in ``istate``.
Per race (shape (B, ...)): integers ``R_*`` in ``rstate``. Packing keeps one kart's state contiguous and
lets the whole world be copied, saved and compared as a handful of arrays.
"""

from __future__ import annotations

# floats per kart
F_X = 0  # [m]
F_Y = 1  # [m]
F_HEADING = 2  # [rad] counter-clockwise from +x, in [-pi, pi)
F_SPEED = 3  # [m/s] along the heading (negative when reversing)
F_YAW_RATE = 4  # [rad/s]
F_ACC_YAW = 5  # [rad] accumulated |yaw|, drives tyre wear
F_S = 6  # [m] progress along the centre line within the lap
F_D = 7  # [m] lateral offset from the centre line, left-positive
F_STEER = 8  # [-] last applied steer input
F_THROTTLE = 9  # [-] last applied throttle input
F_FINISH_TIME = 10  # [s] time of crossing the finish line (interpolated within the step); -1 if not finished
F_DR_SUM = 11  # [m] sum of target-lane distances at checkpoints (delta_r numerator)
F_DV_SUM = 12  # [m/s] sum of target-speed differences at checkpoints (delta_v numerator)
F_WEAR = 13  # [-] tyre wear proportion (derived from F_ACC_YAW, kept for observers)
F_CROSS_TIME = 14  # [s] race time of the last checkpoint crossing (interpolated within the step)
F_CROSS_SPEED = 15  # [m/s] speed at the last checkpoint crossing
F_CROSS_WEAR = 16  # [-] tyre wear at the last checkpoint crossing
F_SLIP = 17  # [rad] slip angle: the centre moves along heading + slip
N_FLOAT = 18

# integers per kart
I_CENTRE_IDX = 0  # centre-line sample nearest to the kart (search hint)
I_CP_PASSED = 1  # checkpoints passed since the start (0 = start line; laps * N = finished)
I_LANE = 2  # lane (1-based) at the last checkpoint crossing
I_LANE_COUNT = 3  # eq. (10) counter sampled at checkpoint crossings (the original's way)
I_ILLEGAL = 4  # illegal lane changes under the race's counting rule (the one in the safety score)
I_FAULTS = 5  # collisions at fault
I_LAST_FAULT_STEP = 6  # step of the last at-fault contact (for the 1.5 s merge window)
I_WALL_HITS = 7  # wall hits (contacts separated by more than the fault cooldown)
I_WALL_CONTACT = 8  # 1 while touching a wall
I_BUFFER_VIOLATIONS = 9  # s0/s1 buffer violations (rising edges, as the nose-side kart)
I_DR_COUNT = 10  # checkpoints that had a target lane
I_DV_COUNT = 11  # checkpoints that had a target speed
I_FINISHED = 12  # 1 once finished
I_CONTACTS = 13  # kart-kart contacts (rising edges), at fault or not
I_EVENTS = 14  # bit mask of what happened to this kart in the last step (EV_*)
I_LAST_WALL_STEP = 15  # step of the last wall contact (contacts within the fault cooldown are one hit)
I_LANE_NOW = 16  # lane (1-based) the kart is in now: lane membership with hysteresis, every step
I_STEP_LANE_COUNT = 17  # eq. (10) counter counted as lane changes happen (every step)
I_ILLEGAL_STEP = 18  # illegal lane changes counted every step (eq. 11)
I_ILLEGAL_CHECKPOINT = 19  # illegal lane changes sampled at checkpoint crossings (the original's rule)
I_PASSES = 20  # overtakes completed and held for PASS_HOLD_STEPS (or to the finish)
N_INT = 21

# integers per race
R_STEP = 0  # steps simulated
R_DONE = 1  # 1 once every kart finished or the time limit passed
N_RACE = 2

# event bits in I_EVENTS
EV_CHECKPOINT = 1
EV_ILLEGAL_LANE_CHANGE = 2
EV_FAULT_COLLISION = 4
EV_WALL_HIT = 8
EV_FINISHED = 16
EV_CONTACT = 32

# ray hit kinds
HIT_NONE = 0
HIT_WALL = 1
HIT_KART = 2

# packed rule parameters (see sim_core.params.SimParams.rule_vector)
RP_TIME_LIMIT_STEPS = 0
RP_LANE_LIMIT = 1
RP_FAULT_COOLDOWN_STEPS = 2
RP_CONTACT_MARGIN = 3
RP_CONE_COS = 4
RP_BUFFER_SIDE = 5
RP_BUFFER_BEHIND = 6
RP_BEHIND_OVERLAP = 7
RP_LANE_DEADZONE = 8
RP_LAPS = 9
RP_DT = 10
RP_RAY_RANGE = 11
RP_RAY_ORIGIN = 12
RP_LANE_HYSTERESIS = 13
RP_LANE_COUNTING = 14  # LANE_COUNTING_PER_STEP or LANE_COUNTING_CHECKPOINT
RP_ALONGSIDE = 15
RP_LATERAL_FAULT_SPEED = 16
N_RULE = 17

# lane-change counting rules (RP_LANE_COUNTING)
LANE_COUNTING_PER_STEP = 0
LANE_COUNTING_CHECKPOINT = 1

# bits of the per-pair flags (World.pair_flags)
PAIR_BUFFER = 1  # the nose-side kart is inside its buffer
PAIR_CONTACT = 2  # the two bodies touch
PAIR_ORDER_KNOWN = 4  # (i < j) the running order of i and j has been established
PAIR_I_AHEAD = 8  # (i < j) i runs ahead of j
# (i < j) counts kept in the flag word's high bits: who touched whom and who passed whom, so that a team's
# contacts between its own karts and its karts letting each other by can be reported apart. Each count saturates
# at its field's largest value (:func:`sim_core.referee.add_pair_count`).
PAIR_CONTACT_SHIFT = 32  # the pair's contacts (12 bits)
PAIR_CONTACT_BITS = 12
PAIR_PASS_I_SHIFT = 44  # passes of j by i (9 bits)
PAIR_PASS_J_SHIFT = 53  # passes of i by j (9 bits)
PAIR_PASS_BITS = 9

PASS_HOLD_STEPS = 100  # a pass counts once the passer has held the place this long (2 s)
PASS_CHECK_STEPS = 5  # the running order is checked every this many steps (10 Hz)
PASS_MARGIN = 0.5  # [m] a change of running order needs this much progress in it (no counting of noise)

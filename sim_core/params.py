"""Physical and rule parameters of the simulation, as frozen dataclasses with named presets.

Units are in brackets on every field. Two kart presets exist:

* ``paper``: the figures the paper states (15 m/s, +4 / -6 m/s^2, 1.5 g).
* ``original``: the Unity implementation's figures (``../shared/spec/original_implementation.md`` section 3):
  acceleration 12 and braking 10 m/s^2 multiplied by a curve that is 2.5x at standstill and 1x at top
  speed, lateral grip 2.0 g fresh falling to 0.5 g worn.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from sim_core import state as st

SIM_HZ = 50  # [Hz] fixed simulation rate, the same live and headless
DT = 1.0 / SIM_HZ  # [s] fixed simulation step
GRAVITY = 9.81  # [m/s^2]
MIN_PACE = 0.5  # the slowest pace handicap (KartParams.paced): half the reference kart's speed


@dataclass(frozen=True)
class KartParams:
    """Kinematic-bicycle kart with a lateral-acceleration limit that falls as the tyres wear."""

    name: str = "paper"
    top_speed: float = 15.0  # [m/s]
    reverse_speed: float = 5.0  # [m/s] top speed backwards
    acceleration: float = 4.0  # [m/s^2] at full throttle (times the curve below)
    braking: float = 6.0  # [m/s^2] at full brake (times the curve below)
    reverse_acceleration: float = 2.0  # [m/s^2] when braking from standstill
    # Multiplier on acceleration and braking at standstill, falling quadratically in v/top_speed to 1
    # at top speed (the Unity kart's "AccelerationCurve"); 1.0 means constant limits.
    low_speed_gain: float = 1.0  # [-]
    coasting_drag: float = 2.0  # [m/s^2] deceleration with no throttle and no brake
    wheelbase: float = 1.27  # [m]
    max_steer_angle: float = 0.45  # [rad] front wheel angle at steer input 1 (about 26 deg)
    lateral_g_fresh: float = 1.5  # [g] lateral limit with new tyres
    lateral_g_worn: float = 0.5  # [g] lateral limit with fully worn tyres
    # Wear w = min(1, wear_gain * (1 - exp(-A / wear_yaw_scale))) with A the accumulated |yaw| [rad].
    wear_yaw_scale: float = 200.0  # [rad]
    wear_gain: float = 4.0 / 3.0  # [-]
    body_half_length: float = 0.55  # [m] half length of the capsule's axis (body length 2.0 m)
    body_radius: float = 0.45  # [m] capsule radius (body width 0.9 m)
    wall_friction: float = 0.5  # [-] Coulomb coefficient: sliding speed lost per unit of speed into a wall
    # A wall turns the body toward its tangent no faster than this (the kart slides along it meanwhile).
    wall_yaw_rate: float = 3.0  # [rad/s]

    @property
    def body_length(self) -> float:
        """[m] nose to tail of the capsule body."""
        return 2.0 * (self.body_half_length + self.body_radius)

    def lateral_limit(self, wear: float | np.ndarray) -> float | np.ndarray:
        """Lateral acceleration limit [m/s^2] for a tyre-wear proportion in [0, 1]."""
        grip_g = self.lateral_g_worn + (1.0 - np.clip(wear, 0.0, 1.0)) * (self.lateral_g_fresh - self.lateral_g_worn)
        return grip_g * GRAVITY

    def wear_from_yaw(self, accumulated_yaw: float | np.ndarray) -> float | np.ndarray:
        """Tyre-wear proportion in [0, 1] after ``accumulated_yaw`` [rad] of total turning."""
        return np.minimum(1.0, self.wear_gain * (1.0 - np.exp(-np.asarray(accumulated_yaw) / self.wear_yaw_scale)))

    def yaw_for_wear(self, wear: float) -> float:
        """Inverse of :meth:`wear_from_yaw`: accumulated yaw [rad] that gives ``wear`` (< 1)."""
        if not 0.0 <= wear < 1.0:
            raise ValueError(f"wear must be in [0, 1), got {wear}")
        return float(-self.wear_yaw_scale * np.log(1.0 - wear / self.wear_gain))

    def throttle_for_acceleration(self, speed: float | np.ndarray, acceleration: float | np.ndarray) -> np.ndarray:
        """Throttle in [-1, 1] realising ``acceleration`` [m/s^2] at forward ``speed`` [m/s], coasting drag included
        (vectorised; the compiled :func:`sim_core.kart.throttle_for_acceleration` is the same inverse)."""
        speed = np.asarray(speed, dtype=float)
        accel = np.nan_to_num(np.asarray(acceleration, dtype=float), nan=0.0)
        ratio = np.minimum(np.abs(speed) / self.top_speed, 1.0)
        curve = self.low_speed_gain + (1.0 - self.low_speed_gain) * ratio * ratio
        drag = self.coasting_drag
        forward = (accel + drag) / (self.acceleration * curve + drag)
        braking = (accel + drag) / (self.braking * curve - drag)
        throttle = np.where(accel >= -drag, forward, braking)
        throttle = np.where((speed <= 1e-3) & (accel <= 0.0), 0.0, throttle)
        return np.clip(throttle, -1.0, 1.0)

    def paced(self, pace: float) -> KartParams:
        """This kart at ``pace`` (a ratio in [``MIN_PACE``, 1]; 1 is this kart): every speed limit times ``pace``, every
        acceleration limit (throttle, brakes, drag, grip) times ``pace**2`` and the wall's turning rate times
        ``pace``. The equations of motion then hold under time scaled by ``1 / pace``: the same inputs drive
        the same path, ``1 / pace`` times slower (the kart's steering geometry, body and wear per radian of
        turning are unchanged). The pace handicap of :mod:`sim_core.conditions` and of agent strings
        ``NAME@PACE``."""
        if not MIN_PACE <= pace <= 1.0:
            raise ValueError(f"pace must be in [{MIN_PACE:g}, 1], got {pace:g}")
        if pace == 1.0:
            return self
        speed, accel = pace, pace * pace
        return replace(
            self,
            name=f"{self.name}@{pace:g}",
            top_speed=self.top_speed * speed,
            reverse_speed=self.reverse_speed * speed,
            acceleration=self.acceleration * accel,
            braking=self.braking * accel,
            reverse_acceleration=self.reverse_acceleration * accel,
            coasting_drag=self.coasting_drag * accel,
            lateral_g_fresh=self.lateral_g_fresh * accel,
            lateral_g_worn=self.lateral_g_worn * accel,
            wall_yaw_rate=self.wall_yaw_rate * speed,
        )

    def as_array(self) -> np.ndarray:
        """Parameters packed for the compiled step kernel (order fixed by :data:`KART_PARAM_FIELDS`)."""
        return np.array([getattr(self, f) for f in KART_PARAM_FIELDS], dtype=np.float64)


KART_PARAM_FIELDS: tuple[str, ...] = (
    "top_speed",
    "reverse_speed",
    "acceleration",
    "braking",
    "reverse_acceleration",
    "low_speed_gain",
    "coasting_drag",
    "wheelbase",
    "max_steer_angle",
    "lateral_g_fresh",
    "lateral_g_worn",
    "wear_yaw_scale",
    "wear_gain",
    "body_half_length",
    "body_radius",
    "wall_friction",
    "wall_yaw_rate",
)

PAPER_KART = KartParams()
ORIGINAL_KART = replace(
    PAPER_KART,
    name="original",
    acceleration=12.0,
    braking=10.0,
    reverse_acceleration=5.0,
    low_speed_gain=2.5,
    lateral_g_fresh=2.0,
    lateral_g_worn=0.5,
)
KART_PRESETS: dict[str, KartParams] = {p.name: p for p in (PAPER_KART, ORIGINAL_KART)}


def kart_preset(name: str) -> KartParams:
    """Look up a kart preset by name (``paper`` or ``original``)."""
    try:
        return KART_PRESETS[name]
    except KeyError:
        raise ValueError(f"unknown kart preset {name!r}; known: {sorted(KART_PRESETS)}") from None


LANE_COUNTING_RULES = ("per_step", "checkpoint")


@dataclass(frozen=True)
class RuleParams:
    """Racing rules and metric settings of the referee (paper section 3, spec section 4)."""

    time_limit: float = 120.0  # [s] a kart that has not finished by then is DNF
    lane_change_limit: int | None = None  # [lanes] L; None takes the track's own limit
    fault_cooldown: float = 1.5  # [s] contact (kart or wall) within this time of the last one is the same one
    contact_margin: float = 0.02  # [m] bodies closer than this are in contact
    fault_cone_cos: float = 0.5  # [-] front touches if the contact normal is within acos(0.5) = 60 deg of heading
    buffer_side: float = 0.5  # [m] s0: minimum nose-to-body distance when not directly behind (eqs. (8)-(9))
    buffer_behind: float = 1.5  # [m] s1: minimum nose-to-body distance when directly behind (eqs. (8)-(9))
    behind_lateral_overlap: float = 1.2  # [m] "directly behind" when lateral offsets differ by less than this
    # Lane changes: "per_step" counts them as they happen (the paper's eqs. (10)-(11)); "checkpoint" samples
    # the lane at checkpoint crossings only (the original implementation, behind the paper's tables).
    # Both counts are recorded in every result; this one is the safety score's.
    lane_change_counting: str = "per_step"
    lane_hysteresis: float = 0.25  # [m] a kart joins a lane this far past the midpoint between two lanes
    # Fault when two karts touch: the follower (the paper's rule), unless they are alongside (the gap
    # between them along the track under this), then the kart that moved laterally into the other.
    alongside_gap: float = (
        1.0  # [m] along the track between the centres: one nose at least level with the other's centre
    )
    lateral_fault_speed: float = 0.3  # [m/s] lateral speed toward the other kart that counts as moving into it
    lane_deadzone: float = 1.3  # [m] delta_r counts max(distance to target lane point - this, 0), as the original
    start_wear: float = 0.25  # [-] tyre wear of every kart at the start of a race

    def __post_init__(self) -> None:
        if self.lane_change_counting not in LANE_COUNTING_RULES:
            raise ValueError(
                f"lane_change_counting must be one of {LANE_COUNTING_RULES}, got {self.lane_change_counting!r}"
            )


@dataclass(frozen=True)
class SensorParams:
    """The 9 range rays of each kart (spec section 6)."""

    angles_deg: tuple[float, ...] = (0.0, 30.0, 45.0, 60.0, 90.0, -30.0, -45.0, -60.0, -90.0)  # [deg] + = right
    max_range: float = 20.0  # [m]
    origin_forward: float = 0.1  # [m] sensor origin ahead of the kart centre

    def angles_rad_left_positive(self) -> np.ndarray:
        """Ray angles [rad] in the counter-clockwise (left-positive) convention used by the kernels."""
        return -np.deg2rad(np.asarray(self.angles_deg, dtype=np.float64))


@dataclass(frozen=True)
class SimParams:
    """Everything a :class:`~sim_core.world.World` needs besides the track."""

    kart: KartParams = field(default_factory=lambda: PAPER_KART)
    rules: RuleParams = field(default_factory=RuleParams)
    sensors: SensorParams = field(default_factory=SensorParams)

    def rule_vector(self, track_lane_limit: int, laps: int) -> np.ndarray:
        """The rules and sensors packed for the compiled step (layout: ``sim_core.state.RP_*``), for a track whose
        own lane-change limit is ``track_lane_limit`` (the rules' limit, when set, overrides it) raced over
        ``laps`` laps."""
        rules, sensors = self.rules, self.sensors
        v = np.zeros(st.N_RULE)
        v[st.RP_TIME_LIMIT_STEPS] = round(rules.time_limit / DT)
        v[st.RP_LANE_LIMIT] = rules.lane_change_limit if rules.lane_change_limit is not None else track_lane_limit
        v[st.RP_FAULT_COOLDOWN_STEPS] = round(rules.fault_cooldown / DT)
        v[st.RP_CONTACT_MARGIN] = rules.contact_margin
        v[st.RP_CONE_COS] = rules.fault_cone_cos
        v[st.RP_BUFFER_SIDE] = rules.buffer_side
        v[st.RP_BUFFER_BEHIND] = rules.buffer_behind
        v[st.RP_BEHIND_OVERLAP] = rules.behind_lateral_overlap
        v[st.RP_LANE_DEADZONE] = rules.lane_deadzone
        v[st.RP_LAPS] = laps
        v[st.RP_DT] = DT
        v[st.RP_RAY_RANGE] = sensors.max_range
        v[st.RP_RAY_ORIGIN] = sensors.origin_forward
        v[st.RP_LANE_HYSTERESIS] = rules.lane_hysteresis
        checkpoint = rules.lane_change_counting == "checkpoint"
        v[st.RP_LANE_COUNTING] = st.LANE_COUNTING_CHECKPOINT if checkpoint else st.LANE_COUNTING_PER_STEP
        v[st.RP_ALONGSIDE] = rules.alongside_gap
        v[st.RP_LATERAL_FAULT_SPEED] = rules.lateral_fault_speed
        return v

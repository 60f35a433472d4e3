"""Contacts within a step: karts pushed out of the walls (sliding along them) and out of each other
(symmetric push, inelastic along the contact normal), relaxed over a few rounds."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from sim_core.geometry import centre_normal, locate, segment_closest, wrap_angle
from sim_core.kart import (
    P_HALF_LENGTH,
    P_RADIUS,
    P_REVERSE_SPEED,
    P_TOP_SPEED,
    P_WALL_FRICTION,
    P_WALL_YAW_RATE,
    max_slip,
)
from sim_core.kernel_arrays import NO_REFCOUNT, PHASE, StepScratch, TrackArrays, WorldArrays
from sim_core.rules import front_touches
from sim_core.state import (
    F_HEADING,
    F_SLIP,
    F_SPEED,
    F_X,
    F_Y,
    I_CENTRE_IDX,
    I_FINISHED,
    RP_CONE_COS,
    RP_CONTACT_MARGIN,
    RP_DT,
)

CONTACT_ROUNDS = 4  # relaxation rounds of wall and kart-kart contact per step


@njit(**PHASE)
def resolve_contacts(
    b: int, w: WorldArrays, tr: TrackArrays, kp: np.ndarray, rp: np.ndarray, scratch: StepScratch
) -> None:
    """Push every kart of race ``b`` out of the walls and the other karts. Sets ``scratch.wall_touch``,
    ``contact`` (any round), ``first_touch`` and ``front`` (the first round: the referee charges faults from
    the contacts as the karts arrived, before the pushes moved them). ``kp``: each kart's parameters (K, P)."""
    F, I = w.F, w.I
    K = F.shape[1]
    dt = rp[RP_DT]
    wall_touch = scratch.wall_touch
    contact = scratch.contact
    first_touch = scratch.first_touch
    front = scratch.front
    heading_before = scratch.heading_before
    located = scratch.located
    wall_touch[:] = False
    contact[:, :] = False
    first_touch[:, :] = False
    margin = rp[RP_CONTACT_MARGIN]
    cone = rp[RP_CONE_COS]
    any_pair = False
    for rnd in range(CONTACT_ROUNDS):
        for k in range(K):
            if not I[b, k, I_FINISHED] and _resolve_walls(tr, kp[k], F, I, b, k, dt, located, heading_before[k]):
                wall_touch[k] = True
        any_pair = False
        for i in range(K):
            if I[b, i, I_FINISHED]:
                continue
            for j in range(i + 1, K):
                if I[b, j, I_FINISHED]:
                    continue
                touching, i_fault, j_fault = _resolve_pair(kp, F, b, i, j, margin, cone)
                if touching:
                    any_pair = True
                    contact[i, j] = True
                    if rnd == 0:
                        first_touch[i, j] = True
                        front[i, j] = i_fault
                        front[j, i] = j_fault
        if not any_pair:
            break
    if any_pair:
        # kart-kart pushes of the last round may have moved a kart into a wall
        for k in range(K):
            if not I[b, k, I_FINISHED] and _resolve_walls(tr, kp[k], F, I, b, k, dt, located, heading_before[k]):
                wall_touch[k] = True


@njit(**NO_REFCOUNT)
def _resolve_walls(
    tr: TrackArrays,
    kp: np.ndarray,
    F: np.ndarray,
    I: np.ndarray,
    b: int,
    k: int,
    dt: float,
    located: np.ndarray,
    heading_before: float,
) -> bool:
    """Push kart k out of the walls; a kart driving into a wall slides along it and loses speed.

    The slide is the kart's direction of travel at once (its slip angle takes the difference, up to the
    kinematic limit); the body turns toward the wall's tangent at most ``wall_yaw_rate`` from
    ``heading_before`` (its heading before this step's contacts), so a wall never snaps the heading.
    ``located[k]`` keeps [x, y, s, d, sample index] of the kart's last located position (the referee reuses
    it when the kart has not moved since).
    """
    hl = kp[P_HALF_LENGTH]
    r = kp[P_RADIUS]
    touched = False
    for _ in range(2):
        x, y, h = F[b, k, F_X], F[b, k, F_Y], F[b, k, F_HEADING]
        idx, s, d = locate(tr, x, y, I[b, k, I_CENTRE_IDX])
        I[b, k, I_CENTRE_IDX] = idx
        located[k, 0], located[k, 1], located[k, 2], located[k, 3], located[k, 4] = x, y, s, d, idx
        # the lateral offset is 1-Lipschitz, so a body within hl of the centre cannot reach a wall that is
        # farther than |d| + hl + r anywhere nearby
        if d + hl + r < tr.near_width_left[idx] and hl + r - d < tr.near_width_right[idx]:
            break
        ch, sh = math.cos(h), math.sin(h)
        worst = 0.0
        push_x, push_y = 0.0, 0.0
        for frac in (1.0, 0.0, -1.0):  # front end, centre, rear end of the body axis
            j, _sj, dj = locate(tr, x + frac * hl * ch, y + frac * hl * sh, idx)
            nx, ny = centre_normal(tr, j)
            over_left = dj + r - tr.width_left[j]
            over_right = -tr.width_right[j] - (dj - r)
            if over_left > worst:
                worst, push_x, push_y = over_left, -nx, -ny
            if over_right > worst:
                worst, push_x, push_y = over_right, nx, ny
        if worst <= 0.0:
            break
        touched = True
        F[b, k, F_X] = x + push_x * worst
        F[b, k, F_Y] = y + push_y * worst
        speed = F[b, k, F_SPEED]
        course = h + F[b, k, F_SLIP]
        ux, uy = speed * math.cos(course), speed * math.sin(course)
        into = ux * push_x + uy * push_y
        if into < 0.0:
            tx, ty = -push_y, push_x  # a wall tangent
            along = ux * tx + uy * ty
            if abs(along) < 1e-9:
                # head-on: slide toward the track's forward direction
                nx, ny = centre_normal(tr, idx)
                along = 1e-9 if (tx * ny - ty * nx) > 0.0 else -1e-9
            sign = 1.0 if along > 0.0 else -1.0
            # Coulomb friction: the harder the kart drives into the wall, the more sliding speed it loses
            slide = max(abs(along) + kp[P_WALL_FRICTION] * into, 0.0)
            slide_dir = math.atan2(sign * ty, sign * tx)
            # the body's course (heading + slip) points along the slide, backwards when reversing
            course_target = slide_dir if speed >= 0.0 else wrap_angle(slide_dir + math.pi)
            turn_limit = kp[P_WALL_YAW_RATE] * dt
            turned = wrap_angle(course_target - heading_before)
            turned = min(max(turned, -turn_limit), turn_limit)
            new_heading = wrap_angle(heading_before + turned)
            slip_limit = max_slip(kp)
            F[b, k, F_HEADING] = new_heading
            F[b, k, F_SLIP] = min(max(wrap_angle(course_target - new_heading), -slip_limit), slip_limit)
            F[b, k, F_SPEED] = slide if speed >= 0.0 else -slide
    return touched


@njit(**NO_REFCOUNT)
def _resolve_pair(
    kp: np.ndarray, F: np.ndarray, b: int, i: int, j: int, margin: float, cone_cos: float
) -> tuple[bool, bool, bool]:
    """Separate karts i and j if their capsules overlap (symmetric push, inelastic along the normal).

    Returns (in contact, i's front touches j, j's front touches i). ``kp``: each kart's parameters (K, P); the
    bodies are the same size for every kart.
    """
    hl = kp[i, P_HALF_LENGTH]
    r = kp[i, P_RADIUS]
    xi, yi, hi = F[b, i, F_X], F[b, i, F_Y], F[b, i, F_HEADING]
    xj, yj, hj = F[b, j, F_X], F[b, j, F_Y], F[b, j, F_HEADING]
    if (xi - xj) ** 2 + (yi - yj) ** 2 > (2.0 * (hl + r) + margin) ** 2:
        return False, False, False
    ci, si_ = math.cos(hi), math.sin(hi)
    cj, sj_ = math.cos(hj), math.sin(hj)
    dist, ti, tj = segment_closest(
        xi - hl * ci,
        yi - hl * si_,
        xi + hl * ci,
        yi + hl * si_,
        xj - hl * cj,
        yj - hl * sj_,
        xj + hl * cj,
        yj + hl * sj_,
    )
    if dist >= 2.0 * r + margin:
        return False, False, False
    # normal from j's closest point to i's closest point
    pix, piy = xi + (2.0 * ti - 1.0) * hl * ci, yi + (2.0 * ti - 1.0) * hl * si_
    pjx, pjy = xj + (2.0 * tj - 1.0) * hl * cj, yj + (2.0 * tj - 1.0) * hl * sj_
    nx, ny = pix - pjx, piy - pjy
    norm = math.sqrt(nx * nx + ny * ny)
    if norm < 1e-9:
        nx, ny = xi - xj, yi - yj
        norm = math.sqrt(nx * nx + ny * ny)
        if norm < 1e-9:
            nx, ny, norm = -si_, ci, 1.0
    nx, ny = nx / norm, ny / norm
    i_faults = front_touches(ti, -(nx * ci + ny * si_), cone_cos)
    j_faults = front_touches(tj, nx * cj + ny * sj_, cone_cos)
    penetration = 2.0 * r - dist
    if penetration > 0.0:
        half = 0.5 * penetration
        F[b, i, F_X] += nx * half
        F[b, i, F_Y] += ny * half
        F[b, j, F_X] -= nx * half
        F[b, j, F_Y] -= ny * half
        vi, vj = F[b, i, F_SPEED], F[b, j, F_SPEED]
        closing = (vi * ci - vj * cj) * nx + (vi * si_ - vj * sj_) * ny
        if closing < 0.0:
            # equal masses, perfectly inelastic along the normal; the no-slip kart keeps its heading component
            uix, uiy = vi * ci - 0.5 * closing * nx, vi * si_ - 0.5 * closing * ny
            ujx, ujy = vj * cj + 0.5 * closing * nx, vj * sj_ + 0.5 * closing * ny
            # a push never takes a kart past its own speed limits
            F[b, i, F_SPEED] = min(max(uix * ci + uiy * si_, -kp[i, P_REVERSE_SPEED]), kp[i, P_TOP_SPEED])
            F[b, j, F_SPEED] = min(max(ujx * cj + ujy * sj_, -kp[j, P_REVERSE_SPEED]), kp[j, P_TOP_SPEED])
    return True, i_faults, j_faults

"""What happens to each move, drawn from uniform variates in one vectorised step.

Every move gets the same `COLUMNS` uniform numbers whatever the model, and
each term reads its own columns, so a seed gives every move the same fate
under every strategy, and a term's probability changing does not reshuffle
the others' draws. The simulator draws all moves of a plan at once
(`simulator_durations`); a virtual robot draws one move at a time from its
own generator (`draw_fates` on one row). Gaussian durations come from the
Box-Muller transform, Poisson counts from the inverse of their distribution
(at most `MAX_EVENTS` events a move; P(more) < 1e-5 for P <= 1).
"""
from __future__ import annotations

import math
from typing import NamedTuple, Tuple

import numpy as np

from .model import DelayModel

MAX_EVENTS = 8
_FACTOR, _DELAY, _SLOW, _STALL, _STALL_AT, _DROP, _DROP_AT, _COUNT, _PRONE = range(9)
_EVENTS = 9  # then 2 columns per event
COLUMNS = _EVENTS + 2 * MAX_EVENTS


class MoveFates(NamedTuple):
    """Per move: wait before it (moves), slowdown factor, stall (moves) and where, dropout."""

    wait: np.ndarray
    slowdown: np.ndarray
    stall: np.ndarray
    stall_at: np.ndarray
    dropout: np.ndarray      # moves away, 0: no dropout
    dropout_at: np.ndarray   # fraction of the move


def robot_profile(model: DelayModel, seed: int, num_robots: int) -> Tuple[np.ndarray, np.ndarray]:
    """(slowdown factor, delay-prone?) per robot: `robot=` terms and BTPG's prone robots."""
    factor = np.ones(num_robots)
    for robot, slow in model.robots:
        if robot < num_robots:
            factor[robot] = slow
    prone = np.zeros(num_robots, dtype=bool)
    q = model.prone
    if q is not None and num_robots:
        count = int(math.ceil(q.fraction * num_robots - 1e-9))
        prone[np.random.default_rng([seed, 7]).permutation(num_robots)[:count]] = True
    return factor, prone


def _event_durations(model: DelayModel, u: np.ndarray) -> np.ndarray:
    """(moves, MAX_EVENTS) durations in whole moves, from the event columns."""
    e = model.events
    assert e is not None
    first = u[:, _EVENTS::2]
    if e.duration == "uniform" or e.max == e.min:
        return e.min + np.minimum(np.floor(first * (e.max - e.min + 1)), e.max - e.min)
    second = u[:, _EVENTS + 1::2]
    z = np.sqrt(-2.0 * np.log(np.maximum(first, 1e-300))) * np.cos(2.0 * math.pi * second)
    span = e.max - e.min
    return np.clip(np.rint(e.min + span * e.mean + span * e.std * z), e.min, e.max)


def _event_counts(model: DelayModel, u: np.ndarray) -> np.ndarray:
    e = model.events
    assert e is not None
    if e.model == "bernoulli":
        return (u < e.p).astype(np.int64)
    cdf, term = [], math.exp(-e.p)
    total = term
    for k in range(MAX_EVENTS):
        cdf.append(total)
        term *= e.p / (k + 1)
        total += term
    return np.searchsorted(np.array(cdf), u, side="right").clip(0, MAX_EVENTS)


def draw_fates(model: DelayModel, u: np.ndarray, robot_factor: np.ndarray,
               prone: np.ndarray) -> MoveFates:
    """Fates of moves with uniform variates `u` (moves x COLUMNS), made by robots whose
    profile values are `robot_factor` and `prone` (one per move)."""
    n = u.shape[0]
    low, high = model.factor
    slowdown = (low + (high - low) * u[:, _FACTOR]) * robot_factor
    if model.slow_p:
        slowdown = slowdown * np.where(u[:, _SLOW] < model.slow_p, model.slow_factor, 1.0)
    wait = model.delay * u[:, _DELAY]
    if model.events is not None and model.events.p > 0:
        counts = _event_counts(model, u[:, _COUNT])
        durations = _event_durations(model, u)
        wait = wait + (durations * (np.arange(MAX_EVENTS) < counts[:, None])).sum(axis=1)
    q = model.prone
    if q is not None and q.p > 0:
        wait = wait + np.where(prone & (u[:, _PRONE] < q.p), q.moves, 0.0)
    stall = np.where(u[:, _STALL] < model.stall_p, model.stall_moves, 0.0) if model.stall_p else np.zeros(n)
    dropout = (np.where(u[:, _DROP] < model.dropout_p, model.dropout_moves, 0.0) if model.dropout_p
               else np.zeros(n))
    return MoveFates(wait, slowdown, stall, u[:, _STALL_AT], dropout, u[:, _DROP_AT])


def simulator_fates(model: DelayModel, robots: np.ndarray, num_robots: int, seed: int,
                    nominal: float = 1.0) -> MoveFates:
    """The fate of each move of a plan whose moves are made by `robots` (flat action order),
    times in units of `nominal`: the wait, the stall and the dropout scaled, the slowdown a
    factor of `nominal` (a move drives for nominal x slowdown)."""
    u = np.random.default_rng(seed).random((robots.shape[0], COLUMNS))
    factor, prone = robot_profile(model, seed, num_robots)
    f = draw_fates(model, u, factor[robots], prone[robots])
    return MoveFates(nominal * f.wait, f.slowdown, nominal * f.stall, f.stall_at, nominal * f.dropout,
                     f.dropout_at)


def simulator_durations(model: DelayModel, robots: np.ndarray, num_robots: int, seed: int,
                        nominal: float = 1.0) -> Tuple[np.ndarray, np.ndarray]:
    """(wait before, duration of) each move, stalls and dropouts counted in the duration (the
    same draws as `simulator_fates`)."""
    f = simulator_fates(model, robots, num_robots, seed, nominal)
    return f.wait, nominal * f.slowdown + f.stall + f.dropout

"""C_envelope: the size (Eq. 5), ratio (Eq. 7) and position (Eq. 8) constraints of a
room of several rectangles, on its bounding box. At a refinement level (paper Sec. 5.3)
the previous box bounds it from inside; a room of several free rectangles gets its
exact bounding box, each side picked by binaries."""

from __future__ import annotations

from functools import partial
from typing import Any

from pyscipopt import Variable, quicksum

from floorplan.solver.miqp.model import LevelModel, _slack
from floorplan.solver.miqp.spec import EnvelopeSpec
from floorplan.solver.miqp.valuation import (
    Size,
    _covering,
    _envelope_miss,
    _envelope_pick,
    _envelope_side,
    _envelope_size,
    _orientation,
    _ratio_miss,
)


def c_envelope(lm: LevelModel) -> None:
    """C_size (Eq. 5) and C_ratio (Eq. 7) on the bounding box of a room of several
    rectangles. Envelope variables bound the true box from outside; the previous box
    bounds it from inside, so the inequalities below are sufficient, never optimistic."""
    m = lm.model
    for e in lm.spec.envelopes:
        if e.previous is None:
            _exact_envelope(lm, e)
            continue
        vs = [lm.rects[n] for n in e.rects]
        tag = e.room
        region, prev = lm.spec.region, e.previous
        # At given boxes: their bounding box, within the variables' bounds (any value
        # between it and the previous box satisfies the sandwich; the tightest is best).
        x0 = lm.derive(m.addVar(f"env_x0[{tag}]", lb=region.x0, ub=prev.x0),
                       partial(_envelope_side, e.rects, "x0", region.x0, prev.x0))
        x1 = lm.derive(m.addVar(f"env_x1[{tag}]", lb=prev.x1, ub=region.x1),
                       partial(_envelope_side, e.rects, "x1", prev.x1, region.x1))
        y0 = lm.derive(m.addVar(f"env_y0[{tag}]", lb=region.y0, ub=prev.y0),
                       partial(_envelope_side, e.rects, "y0", region.y0, prev.y0))
        y1 = lm.derive(m.addVar(f"env_y1[{tag}]", lb=prev.y1, ub=region.y1),
                       partial(_envelope_side, e.rects, "y1", prev.y1, region.y1))
        for k, v in enumerate(vs):
            m.addCons(x0 <= v.x, name=f"env_w[{tag},{k}]")
            m.addCons(x1 >= v.x + v.w, name=f"env_e[{tag},{k}]")
            m.addCons(y0 <= v.y, name=f"env_s[{tag},{k}]")
            m.addCons(y1 >= v.y + v.d, name=f"env_n[{tag},{k}]")
        m.addCons(x1 - x0 <= e.max_size[0], name=f"env_wmax[{tag}]")
        m.addCons(y1 - y0 <= e.max_size[1], name=f"env_dmax[{tag}]")
        if e.aspect_ratio is not None:
            lo, hi = e.aspect_ratio
            w0, d0 = e.previous.width, e.previous.depth
            # Keep the orientation the room already has: long side / short side stays
            # within [lo, hi] whatever the true box is inside the sandwich.
            if w0 >= d0:
                m.addCons(x1 - x0 <= hi * d0, name=f"env_ratio_hi[{tag}]")
                m.addCons(lo * (y1 - y0) <= w0, name=f"env_ratio_lo[{tag}]")
            else:
                m.addCons(y1 - y0 <= hi * w0, name=f"env_ratio_hi[{tag}]")
                m.addCons(lo * (x1 - x0) <= d0, name=f"env_ratio_lo[{tag}]")


def _exact_envelope(lm: LevelModel, e: EnvelopeSpec) -> None:
    """C_size (Eq. 5), C_ratio (Eq. 7) and C_pos (Eq. 8) on the exact bounding box of a
    room of several free rectangles: each side of the box is the extreme side of one
    rectangle, picked by a binary, and a binary picks the orientation as in c_ratio."""
    m, region = lm.model, lm.spec.region
    vs = [lm.rects[n] for n in e.rects]
    tag = e.room
    mx, my = lm.big_m_x, lm.big_m_y
    sides = {
        "x0": ([v.x for v in vs], region.x0, region.x1, mx, -1),
        "x1": ([v.x + v.w for v in vs], region.x0, region.x1, mx, 1),
        "y0": ([v.y for v in vs], region.y0, region.y1, my, -1),
        "y1": ([v.y + v.d for v in vs], region.y0, region.y1, my, 1),
    }
    box: dict[str, Variable] = {}
    for side, (values, lo, hi, big, outward) in sides.items():
        # At given boxes: the bounding box's side, and the first rectangle on it.
        edge = box[side] = lm.derive(m.addVar(f"env_{side}[{tag}]", lb=lo, ub=hi),
                                     partial(_envelope_side, e.rects, side, lo, hi))
        picks = [lm.derive(m.addVar(f"env_pick[{tag},{side},{k}]", vtype="B"),
                           partial(_envelope_pick, e.rects, side, k))
                 for k in range(len(vs))]
        m.addCons(quicksum(picks) == 1, name=f"env_one[{tag},{side}]")
        for k, (value, pick) in enumerate(zip(values, picks, strict=True)):
            # outward -1: the box's low side is at or below every rectangle's, and equal
            # to the picked one's; +1 likewise for the high side.
            m.addCons(outward * (edge - value) >= 0, name=f"env_out[{tag},{side},{k}]")
            m.addCons(outward * (edge - value) <= big * (1 - pick),
                      name=f"env_at[{tag},{side},{k}]")
    for k, (px, py) in enumerate(e.positions):
        # C_pos (Eq. 8) on the room: one rectangle, picked by a binary, covers the point.
        # At given boxes: the first rectangle nearest to the point.
        picks = [lm.derive(m.addVar(f"env_pos[{tag},{k},{j}]", vtype="B"),
                           partial(_covering, e.rects, (px, py), j))
                 for j in range(len(vs))]
        m.addCons(quicksum(picks) == 1, name=f"env_pos_one[{tag},{k}]")
        for j, (v, pick) in enumerate(zip(vs, picks, strict=True)):
            off = 1 - pick
            m.addCons(v.x <= px + mx * off, name=f"env_pos_w[{tag},{k},{j}]")
            m.addCons(v.x + v.w >= px - mx * off, name=f"env_pos_e[{tag},{k},{j}]")
            m.addCons(v.y <= py + my * off, name=f"env_pos_s[{tag},{k},{j}]")
            m.addCons(v.y + v.d >= py - my * off, name=f"env_pos_n[{tag},{k},{j}]")
    width, depth = box["x1"] - box["x0"], box["y1"] - box["y0"]
    size = partial(_envelope_size, e.rects)
    if "min_size" in e.soft:
        m.addCons(width + _slack(lm, f"env_min_w[{tag}]",
                                 partial(_envelope_miss, size, 0, e.min_size[0], -1))
                  >= e.min_size[0], name=f"env_wmin[{tag}]")
        m.addCons(depth + _slack(lm, f"env_min_d[{tag}]",
                                 partial(_envelope_miss, size, 1, e.min_size[1], -1))
                  >= e.min_size[1], name=f"env_dmin[{tag}]")
    else:
        m.addCons(width >= e.min_size[0], name=f"env_wmin[{tag}]")
        m.addCons(depth >= e.min_size[1], name=f"env_dmin[{tag}]")
    if "max_size" in e.soft:
        m.addCons(width - _slack(lm, f"env_max_w[{tag}]",
                                 partial(_envelope_miss, size, 0, e.max_size[0], 1))
                  <= e.max_size[0], name=f"env_wmax[{tag}]")
        m.addCons(depth - _slack(lm, f"env_max_d[{tag}]",
                                 partial(_envelope_miss, size, 1, e.max_size[1], 1))
                  <= e.max_size[1], name=f"env_dmax[{tag}]")
    else:
        m.addCons(width <= e.max_size[0], name=f"env_wmax[{tag}]")
        m.addCons(depth <= e.max_size[1], name=f"env_dmax[{tag}]")
    if e.aspect_ratio is not None:
        slack = (_slack(lm, f"env_ratio[{tag}]", partial(_ratio_miss, size, e.aspect_ratio))
                 if "aspect_ratio" in e.soft else None)
        _either_orientation(lm, width, depth, e.aspect_ratio, tag=tag, prefix="env_",
                            slack=slack, size=size)


def _either_orientation(lm: LevelModel, width: Any, depth: Any, ratio: tuple[float, float],
                        *, tag: str, size: Size, prefix: str = "",
                        slack: Variable | None = None) -> None:
    """lo <= long/short <= hi for a width and depth (variables or expressions, whose
    values at given boxes `size` gives), a binary sigma choosing which side is the long
    one (sigma = 1: a vertical room). With a `slack` (soft), the long side may miss
    [lo, hi] x the short side by it."""
    m, (lo, hi) = lm.model, ratio
    s: Any = 0.0 if slack is None else slack
    big = hi * max(lm.big_m_x, lm.big_m_y)
    tall = lm.derive(m.addVar(f"{prefix}tall[{tag}]", vtype="B"),
                     lambda boxes: _orientation(*size(boxes), ratio)[0])
    m.addCons(lo * depth <= width + big * tall + s, name=f"{prefix}ratio_wide_lo[{tag}]")
    m.addCons(hi * depth >= width - big * tall - s, name=f"{prefix}ratio_wide_hi[{tag}]")
    m.addCons(lo * width <= depth + big * (1 - tall) + s,
              name=f"{prefix}ratio_tall_lo[{tag}]")
    m.addCons(hi * width >= depth - big * (1 - tall) - s,
              name=f"{prefix}ratio_tall_hi[{tag}]")

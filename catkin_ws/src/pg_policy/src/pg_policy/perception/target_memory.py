"""The target memory of one episode: where the target was last seen, what covers that place while it is hidden,
whether it has left the workspace, and which pushes changed nothing.

The one episode protocol (pg_policy.target_loop.episode) keeps a TargetMemory for the ROS call, the evaluation trial
and the training episode, tells it every observation (`see`) and every action (`acted`), and hands the policy a
TargetSearch with each observation (`obs.search`). Policies read it through pg_policy.policies.policy.goal_or_all:
while the target is hidden, the goal is what covers the place it was last seen (`TargetSearch.goal`), so pushes and
grasps go there instead of anywhere in the scene; when nothing covers that place either, the goal falls back to every
object (goal-agnostic).

The target has left the workspace (`TargetMemory.lost`) when it is hidden after being last seen at the edge:
- seen leaving: last seen with a cell within LEAVING_CELLS of the heightmap border (partly outside already), then
  hidden in the next observation;
- last seen within EDGE_CELLS of the border, then hidden in LOST_AFTER_HIDDEN observations in a row.
A target hidden in the middle of the workspace is never lost: it is searched for, as long as the search has
somewhere to look. The search is over (`TargetMemory.not_found`) after `search_limit` observations in a row with the
target hidden and nothing covering the place it was last seen (no search goal): then it is neither under what lies
there nor in view, and the goal-agnostic actions that remain would only lift or push other objects. The limit
depends on how the mask is made (the episode's caller chooses): SEARCH_LIMIT_EXACT for a colour's mask, which is
exact, so that a hidden target lies under something; SEARCH_LIMIT_TRACKED for a tracked point or mask target, whose
"hidden" mostly means that the tracker lost an object lying in view (docs/RESULTS.md, "Searches that find
nothing"). None: the search never ends.

A push "changed nothing" when fewer than pg_policy.perception.scene_change.CHANGE_MIN_CELLS cells within
FUTILE_WATCH_RADIUS_M of its start changed height by CHANGE_DEPTH_M or more (either way) from the heightmap it was
decided on to the next one; such a push is not to be repeated at the same rotation index within
FUTILE_PUSH_RADIUS_M of its start (`TargetSearch.is_futile_repeat`).

Frames and units: masks are (H, W) bool over the heightmap cells (pg_core.heightmap: rows along y, columns along x);
positions are cell indices (row, col) or `world` metres (x, y); heights and distances in metres. An observation's
`index` is the number of actions taken before it (0: the first observation of the episode).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from pg_core.heightmap import OBJECT_HEIGHT_M, Heightmap, cell_centres, world_to_pixel
from pg_core.target_mask import MIN_VISIBLE_CELLS, dilate_mask
from pg_policy.perception.scene_change import CHANGE_MIN_CELLS, changed_cells

SEARCH_RADIUS_M = 0.03  # while hidden, the goal is the object cells within this of the last-seen target mask
MIN_SEARCH_CELLS = 10  # fewer object cells there: nothing covers the last-seen place (goal-agnostic fallback)
LEAVING_CELLS = 2  # last seen this close to the heightmap border (cells): partly outside, seen leaving
EDGE_CELLS = 10  # last seen this close to the border (cells; 2 cm at 0.002 m): at the workspace edge
LOST_AFTER_HIDDEN = 2  # observations in a row without the target, after last seen at the edge, that make it lost
SEARCH_LIMIT_EXACT = 8  # observations hidden with nothing over the last-seen place that end a colour target's search
SEARCH_LIMIT_TRACKED = 4  # the same for a tracked point or mask target (the tracker's "not found")
FUTILE_PUSH_RADIUS_M = 0.01  # a push that changed nothing is not repeated within this of its start (same rotation)
FUTILE_WATCH_RADIUS_M = 0.15  # a push changed something when heights changed within this of its start (m): its
# 0.13 m path in any direction


def search_limit(tracked: bool) -> int:
    """The search limit of a target named by a colour (`tracked` False) or tracked from a point or a mask."""
    return SEARCH_LIMIT_TRACKED if tracked else SEARCH_LIMIT_EXACT


Push = tuple[int, float, float]  # (rotation index, x, y in `world` metres) of a push's start


@dataclass(frozen=True)
class Sighting:
    """The target as last seen: its mask ((H, W) bool), cell count, centroid in cells (row, col) and in `world`
    metres (x, y), the index of that observation and the distance (cells) of its nearest cell to the heightmap
    border (0: on the border row or column)."""

    mask: np.ndarray
    cells: int
    row: float
    col: float
    x: float
    y: float
    index: int
    border_cells: int

    @property
    def leaving(self) -> bool:
        """Partly outside the heightmap already (within LEAVING_CELLS of its border)."""
        return self.border_cells <= LEAVING_CELLS

    @property
    def at_edge(self) -> bool:
        """At the workspace edge (within EDGE_CELLS of the heightmap border)."""
        return self.border_cells <= EDGE_CELLS

    @property
    def where(self) -> str:
        """'(x, y)' in `world` metres, 3 decimals."""
        return f"({self.x:.3f}, {self.y:.3f})"


@dataclass(frozen=True)
class TargetSearch:
    """What the memory knows with one observation (handed to the policy as `obs.search`): whether the target is
    visible (at least `min_cells` cells), its cells now, its last sighting (None: never seen), the observations in a
    row without it (0 while visible), the pushes that changed nothing in this episode, and the observations in a row
    without it while nothing covered its last-seen place (`uncovered_for`, 0 while visible or searched for)."""

    visible: bool
    cells: int
    last_seen: Sighting | None
    hidden_for: int
    futile_pushes: tuple[Push, ...] = ()
    futile_radius_m: float = FUTILE_PUSH_RADIUS_M
    uncovered_for: int = 0

    def goal(self, hm: Heightmap, object_height_m: float = OBJECT_HEIGHT_M) -> np.ndarray | None:
        """(H, W) bool search goal while the target is hidden: the valid cells higher than `object_height_m` (m; by
        default those holding an object, pg_core.heightmap) within SEARCH_RADIUS_M of the last-seen mask, i.e. what
        covers the place the target was last seen. None while it is visible, when it was never seen, or when fewer
        than MIN_SEARCH_CELLS cells cover that place."""
        if self.visible or self.last_seen is None:
            return None
        near = dilate_mask(self.last_seen.mask, hm.resolution, SEARCH_RADIUS_M)
        goal = near & hm.valid & (hm.height > object_height_m)
        return goal if int(goal.sum()) >= MIN_SEARCH_CELLS else None

    def note(self, searching: bool) -> str:
        """What a policy does about a hidden target, for its decision note: searching where the target was last
        seen (`searching`: a search goal exists), or why not."""
        if self.last_seen is None:
            return "target hidden: never seen"
        if searching:
            return f"target hidden: searching where last seen {self.last_seen.where}"
        return f"target hidden: nothing covers where it was last seen {self.last_seen.where}: every object"

    def is_futile_repeat(self, primitive: str, rotation: int, x: float, y: float) -> bool:
        """Whether a push at rotation index `rotation` starting at (x, y) (`world` m) repeats a push that changed
        nothing: same rotation, start within `futile_radius_m`. Grasps never do."""
        if primitive != "push":
            return False
        r2 = self.futile_radius_m**2
        return any(r == int(rotation) and (x - fx) ** 2 + (y - fy) ** 2 <= r2 for r, fx, fy in self.futile_pushes)


def border_distance(mask: np.ndarray) -> int:
    """Cells between the non-empty (H, W) bool `mask` and the nearest heightmap border (0: on the border)."""
    rows, cols = np.nonzero(mask)
    h, w = mask.shape
    return int(min(rows.min(), cols.min(), h - 1 - rows.max(), w - 1 - cols.max()))


class TargetMemory:
    """One episode's memory (module docstring). `min_cells`: target cells from which the target counts as visible.
    `search_limit`: observations hidden with nothing over the last-seen place that end the search (module docstring;
    None: never; ValueError below 1). Not thread-safe; one per running episode."""

    def __init__(self, min_cells: int = MIN_VISIBLE_CELLS, futile_radius_m: float = FUTILE_PUSH_RADIUS_M,
                 search_limit: int | None = SEARCH_LIMIT_EXACT) -> None:
        if search_limit is not None and (isinstance(search_limit, bool) or int(search_limit) != search_limit
                                         or search_limit < 1):
            raise ValueError(f"search_limit must be an integer >= 1 or None, got {search_limit!r}")
        self.min_cells = int(min_cells)
        self.futile_radius_m = float(futile_radius_m)
        self.search_limit = None if search_limit is None else int(search_limit)
        self.reset()

    def reset(self) -> None:
        """Forget everything: a new episode."""
        self.last_seen: Sighting | None = None
        self.hidden_for = 0
        self.uncovered_for = 0
        self.futile: list[Push] = []
        self.search = TargetSearch(False, 0, None, 0, (), self.futile_radius_m)
        self._hm: Heightmap | None = None  # the heightmap of the latest observation
        self._push: tuple[Push, Heightmap] | None = None  # an executed push whose effect is not judged yet

    def see(self, hm: Heightmap, target: np.ndarray, index: int) -> TargetSearch:
        """Take one observation: `hm` and the target's (H, W) bool mask in it; `index` = actions taken before it.
        Judges the push told by `acted` since the last observation (futile or not) and returns the TargetSearch to
        act on. Raises ValueError when the mask's shape differs from the heightmap's."""
        target = np.asarray(target, dtype=bool)
        if target.shape != hm.height.shape:
            raise ValueError(f"target mask {target.shape} and heightmap {hm.height.shape} differ")
        if self._push is not None:
            (rot, x, y), before = self._push
            if before.height.shape == hm.height.shape and not self._changed(before, hm, x, y):
                self.futile.append((rot, x, y))
        self._push, self._hm = None, hm
        cells = int(target.sum())
        visible = cells >= self.min_cells
        if visible:
            rows, cols = np.nonzero(target)
            row, col = float(rows.mean()), float(cols.mean())
            x, y = cell_centres(np.array(row), np.array(col), hm.bounds, hm.resolution)
            self.last_seen = Sighting(target.copy(), cells, row, col, float(x), float(y), int(index),
                                      border_distance(target))
            self.hidden_for = 0
        else:
            self.hidden_for += 1
        search = TargetSearch(visible, cells, self.last_seen, self.hidden_for, tuple(self.futile), self.futile_radius_m)
        uncovered = not visible and self.last_seen is not None and search.goal(hm) is None
        self.uncovered_for = self.uncovered_for + 1 if uncovered else 0
        self.search = replace(search, uncovered_for=self.uncovered_for)
        return self.search

    def acted(self, primitive: str, rotation: int, x: float, y: float, executed: bool) -> None:
        """The action decided on the latest observation: primitive, rotation index and start (x, y) in `world` m;
        `executed`: it moved (a refused action changes nothing and is not judged)."""
        if primitive == "push" and executed and self._hm is not None:
            self._push = ((int(rotation), float(x), float(y)), self._hm)

    @staticmethod
    def _changed(before: Heightmap, after: Heightmap, x: float, y: float) -> bool:
        """Whether heights changed within FUTILE_WATCH_RADIUS_M of (x, y) (module docstring)."""
        row, col = world_to_pixel(x, y, before.bounds, before.resolution)
        row, col = min(max(row, 0), before.height.shape[0] - 1), min(max(col, 0), before.height.shape[1] - 1)
        start = np.zeros(before.height.shape, dtype=bool)
        start[row, col] = True
        n = changed_cells(before, after, start, radius_m=FUTILE_WATCH_RADIUS_M, decrease_only=False, hull=False)
        return n >= CHANGE_MIN_CELLS

    def lost(self) -> str | None:
        """Why the target has left the workspace (module docstring), None while it has not: visible, never seen, or
        hidden away from the edge (searched for)."""
        seen = self.last_seen
        if self.search.visible or seen is None or self.hidden_for == 0:
            return None
        if seen.leaving:
            return f"seen leaving the workspace at {seen.where}"
        if seen.at_edge and self.hidden_for >= LOST_AFTER_HIDDEN:
            return f"hidden for {self.hidden_for} actions since last seen at the workspace edge {seen.where}"
        return None

    def not_found(self) -> str | None:
        """Why the search for a hidden target is over (module docstring), None while it goes on: visible, never seen,
        searched for under what covers its last-seen place, or fewer than `search_limit` observations in a row
        without either."""
        seen = self.last_seen
        if self.search_limit is None or seen is None or self.uncovered_for < self.search_limit:
            return None
        return (f"not in view for {self.uncovered_for} observations in a row, and nothing covers where it was last "
                f"seen {seen.where}")

"""Joint graph of a scene: spanning tree from ground, cut joints (one per independent loop).

The tree decides the generalized coordinates: every bar has its absolute angle theta; a bar
reached from ground through a slider also has the slider's travel ``s``; elastic bars add
their axial (f) and transverse (g) amplitudes. Joints outside the tree are *cut*: each closes
one independent loop and gives the closure equations (11) (2 rows for a pin, 1 for a slider).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from symgen.errors import SceneError
from symgen.scene.model import GROUND, Joint, Scene


@dataclass(frozen=True)
class TreeEdge:
    """How a bar hangs from its parent: ``joint`` joins ``parent`` (a bar or ground) to ``body``."""

    joint: str
    body: str
    parent: str
    body_xi: float  # where the joint is on ``body``
    parent_xi: float | None  # where it is on the parent bar (None: ground)
    ground_point: tuple[float, float] | None  # ground end of the joint (None: parent is a bar)
    slider: bool  # joined through a slider: adds a travel coordinate s


@dataclass(frozen=True)
class CutJoint:
    """A joint outside the spanning tree, closing one independent loop."""

    joint: str
    kind: str  # "pin" | "slider"
    loop: tuple[str, ...]  # bars around the loop (for messages), ground shown as "ground"


@dataclass(frozen=True)
class Topology:
    order: tuple[str, ...]  # bars in tree order (parents before children)
    edges: dict  # body -> TreeEdge
    children: dict  # body -> tuple of TreeEdge hanging from it
    cuts: tuple[CutJoint, ...]

    @property
    def n_loops(self) -> int:
        return len(self.cuts)


def build_topology(scene: Scene) -> Topology:
    """Breadth-first spanning tree from ground (pins preferred), the rest are cut joints."""
    incident: dict[str, list[Joint]] = {GROUND: []}
    for body in scene.bodies:
        incident[body.name] = []
    for j in scene.joints:
        for end in j.ends:
            incident[end.body].append(j)

    edges: dict[str, TreeEdge] = {}
    parent_of: dict[str, str] = {}
    used: set[str] = set()
    order: list[str] = []

    def attach(node: str, j: Joint) -> str:
        here = 0 if j.ends[0].body == node else 1
        near, far = j.ends[here], j.ends[1 - here]
        child = far.body
        parent_xi = None if node == GROUND else near.xi
        assert far.xi is not None and (node == GROUND or parent_xi is not None), "pins and sliders hold bars at a xi"
        used.add(j.name)
        edges[child] = TreeEdge(
            joint=j.name,
            body=child,
            parent=node,
            body_xi=float(far.xi),
            parent_xi=None if parent_xi is None else float(parent_xi),
            ground_point=near.point if node == GROUND else None,
            slider=(j.kind == "slider"),
        )
        parent_of[child] = node
        order.append(child)
        return child

    def reachable(node: str, j: Joint) -> bool:
        child = j.ends[1].body if j.ends[0].body == node else j.ends[0].body
        return j.name not in used and child != GROUND and child not in edges and child != node

    # breadth-first through pins; a slider enters the tree only where no pin reaches a bar
    queue = deque([GROUND])
    while True:
        while queue:
            node = queue.popleft()
            for j in incident[node]:
                if j.kind == "pin" and reachable(node, j):
                    queue.append(attach(node, j))
        nxt = next(
            (
                (node, j)
                for node in [GROUND, *order]
                for j in incident[node]
                if j.kind == "slider" and reachable(node, j)
            ),
            None,
        )
        if nxt is None:
            break
        queue.append(attach(*nxt))

    missing = [b.name for b in scene.bodies if b.name not in edges]
    if missing:
        raise SceneError(
            scene.path,
            f"bodies.{missing[0]}",
            "this bar is not connected to ground through joints",
            "add a pin or slider joining it to the mechanism",
        )

    def path_to_ground(body: str) -> list[str]:
        out = [body]
        while out[-1] != GROUND:
            out.append(parent_of[out[-1]])
        return out

    cuts = []
    for j in scene.joints:
        if j.name in used:
            continue
        a, b = j.ends[0].body, j.ends[1].body
        pa, pb = path_to_ground(a), path_to_ground(b)
        common = next(x for x in pa if x in pb)
        loop = pa[: pa.index(common) + 1] + list(reversed(pb[: pb.index(common)]))
        cuts.append(CutJoint(joint=j.name, kind=j.kind, loop=tuple(loop)))

    children: dict[str, tuple[TreeEdge, ...]] = {name: () for name in [GROUND, *order]}
    for e in edges.values():
        children[e.parent] = children[e.parent] + (e,)
    return Topology(order=tuple(order), edges=edges, children=children, cuts=tuple(cuts))

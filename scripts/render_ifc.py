"""Render exported IFC models with ifcopenshell's geometry module, for docs/exports.md:
house-13 from above and the two-storey example in axonometry, from the layouts
committed in examples/ (no solve).

    python scripts/render_ifc.py [docs/ifc-export.png]
"""

from __future__ import annotations

import sys
from pathlib import Path

import ifcopenshell
import ifcopenshell.geom
import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from floorplan.models import Layout, Problem
from floorplan.solver.export.ifc import to_ifc

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
#: Face colour and opacity per IFC class; spaces are drawn from above only.
STYLE = {"IfcWall": ("#6b6b6b", 1.0), "IfcDoor": ("#8a5a2b", 1.0),
         "IfcWindow": ("#3a7bd5", 0.8), "IfcSpace": ("#f6e2b3", 0.35),
         "IfcColumn": ("#aa4488", 1.0), "IfcBuildingElementProxy": ("#aa4488", 1.0)}


def export(name: str) -> ifcopenshell.file:
    problem = Problem.model_validate_json((EXAMPLES / f"{name}.json").read_text())
    layout = Layout.model_validate_json((EXAMPLES / f"{name}.layout.json").read_text())
    return ifcopenshell.file.from_string(to_ifc(problem, layout).decode())


def triangles(model: ifcopenshell.file) -> list[tuple[str, np.ndarray]]:
    """(IFC class, its triangles as an n x 3 x 3 array) per element, in world
    coordinates, walls with their openings cut."""
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    found = []
    for ifc_class in STYLE:
        for element in model.by_type(ifc_class):
            if element.Representation is None and not ifc_class.startswith(("IfcDoor",
                                                                             "IfcWindow")):
                continue
            shape = ifcopenshell.geom.create_shape(settings, element)
            verts = np.array(shape.geometry.verts).reshape(-1, 3)
            faces = np.array(shape.geometry.faces).reshape(-1, 3)
            found.append((ifc_class, verts[faces]))
    return found


def draw_plan(ax: plt.Axes, model: ifcopenshell.file) -> None:
    """From above: spaces' floors, then walls, doors and windows cut at 1.2 m."""
    for ifc_class, tris in triangles(model):
        colour, alpha = STYLE[ifc_class]
        if ifc_class == "IfcSpace":
            tris = tris[np.all(np.isclose(tris[:, :, 2], tris[:, :, 2].min()), axis=1)]
        for tri in tris:
            ax.fill(tri[:, 0], tri[:, 1], color=colour, alpha=alpha, lw=0)
    for space in model.by_type("IfcSpace"):
        ring = space.Representation.Representations[0].Items[0].SweptArea.OuterCurve
        xy = np.array(ring.Points.CoordList)
        ax.text(*xy.mean(axis=0), f"{space.Name}\n{space.LongName}", ha="center",
                va="center", fontsize=7)
    ax.set_aspect("equal")
    ax.set_axis_off()


def shaded(tris: np.ndarray, colour: str, alpha: float) -> np.ndarray:
    """A colour per triangle, darker the more it turns from a light above and left."""
    normals = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    light = np.array([-0.4, -0.6, 0.7]) / np.linalg.norm([-0.4, -0.6, 0.7])
    intensity = 0.55 + 0.45 * np.abs(normals @ light)
    rgba = np.tile(matplotlib.colors.to_rgba(colour, alpha), (len(tris), 1))
    rgba[:, :3] *= intensity[:, None]
    return rgba


def draw_axonometric(ax: plt.Axes, model: ifcopenshell.file) -> None:
    shapes = [(c, t) for c, t in triangles(model) if c != "IfcSpace"]
    for ifc_class, tris in shapes:
        colour, alpha = STYLE[ifc_class]
        ax.add_collection3d(Poly3DCollection(tris, facecolors=shaded(tris, colour, alpha),
                                             edgecolors="none"))
    points = np.concatenate([t.reshape(-1, 3) for _, t in shapes])
    lo, hi = points.min(axis=0), points.max(axis=0)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(hi - lo)
    ax.view_init(elev=32, azim=-58)
    ax.set_axis_off()


def main(target: str = "docs/ifc-export.png") -> None:
    fig = plt.figure(figsize=(14, 6.5))
    plan = fig.add_subplot(1, 2, 1)
    draw_plan(plan, export("house-13"))
    plan.set_title("house-13.ifc from above: spaces, walls, doors, windows")
    axo = fig.add_subplot(1, 2, 2, projection="3d")
    draw_axonometric(axo, export("two-storey-house"))
    axo.set_title("two-storey-house.ifc: two storeys of walls, doors and windows")
    fig.tight_layout()
    fig.savefig(target, dpi=110)


if __name__ == "__main__":
    main(*sys.argv[1:])

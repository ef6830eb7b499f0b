"""Networks from functional specifications (Peng et al., SIGGRAPH 2016): a mesh of the
floor (`mesh`), the IP choosing a network of its edges (`formulation`, solved by `solve`),
measures of a network on the graph alone (`measure`), and the paper's stochastic search
baseline (`stochastic`). The corridors of a floor are built on it
(`solver.pipeline.corridors`)."""

from floorplan.solver.network.formulation import Feature, NetworkSpec, build_network
from floorplan.solver.network.measure import dead_ends, distances, islands, judge, uncovered
from floorplan.solver.network.mesh import Mesh, cell_polygon, grid_mesh
from floorplan.solver.network.solve import NetworkResult, NetworkStatus, solve_network

__all__ = [
    "Feature",
    "Mesh",
    "NetworkResult",
    "NetworkSpec",
    "NetworkStatus",
    "build_network",
    "cell_polygon",
    "dead_ends",
    "distances",
    "grid_mesh",
    "islands",
    "judge",
    "solve_network",
    "uncovered",
]

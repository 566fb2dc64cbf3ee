"""The blob mesher: a watertight triangle mesh of a metaball surface with a measured error
bound (numpy, scipy and scikit-image; no Mitsuba). The ``blob`` shape plugin builds its mesh
here; the harness's blob sweep, the benchmarks and the tests call it directly.

>>> from codermind.blobmesh import build_blob_mesh
>>> m = build_blob_mesh([[0, 0, 0], [1.5, 0, 0]], 1.0, "tutorial", max_error=0.01)
>>> m.vertices, m.faces, m.normals, m.achieved_error, m.info["cell_size"]

Modules: :mod:`.field` (the two fields), :mod:`.roots` (root finding onto the surface and
the creases), :mod:`.geom` (mesh geometry, sliver clean-up), :mod:`.creases` (cutting the
mesh along the zone field's creases), :mod:`.mesh` (the pipeline, :func:`build_blob_mesh`),
:mod:`.cost` (its cost, estimated before meshing: :func:`estimate_cost`).
"""

from __future__ import annotations

from .cost import Cost, estimate_cost
from .field import FIELDS
from .geom import min_angles_deg
from .mesh import NORMALS, BlobMesh, BlobMeshError, build_blob_mesh

__all__ = ["Cost", "FIELDS", "NORMALS", "BlobMesh", "BlobMeshError", "build_blob_mesh",
           "estimate_cost", "min_angles_deg"]

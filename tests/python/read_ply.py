"""Reads a PLY volmap wrote with the `plyfile` package and prints its vertex properties as JSON,
as MeshLab sees them: MeshLab colours a mesh by the vertex property `quality`.

usage: read_ply.py FILE.ply
"""
import json
import sys

from plyfile import PlyData

ply = PlyData.read(sys.argv[1])
vertex = ply["vertex"]
print(json.dumps({
    "properties": [p.name for p in vertex.properties],
    "vertex": {p.name: vertex[p.name].tolist() for p in vertex.properties},
    "faces": [list(map(int, f)) for f in ply["face"]["vertex_indices"]],
}))

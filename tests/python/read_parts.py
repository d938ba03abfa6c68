"""Reads a five-axis map (a multi-part volmap field, one part per pose) with the Python OpenEXR
package, the way users do, and prints as JSON the parts' names and, for the part named, its
header attributes and VE/OE at the requested grid points.

usage: read_parts.py FIELD.exr PART-NAME i,j,k [i,j,k ...]
"""
import json
import sys

import numpy as np
import OpenEXR

path, wanted, points = sys.argv[1], sys.argv[2], sys.argv[3:]
with OpenEXR.File(path, separate_channels=True) as f:
    parts = f.parts
    names = [p.name() for p in parts]
    part = parts[names.index(wanted)]
    header = part.header
    nx, ny, nz = (int(v) for v in header["volmap.dims"])
    # Pixel (i, j + k*ny) holds grid point (i, j, k): rows are y, columns x.
    field = {name: c.pixels.reshape(nz, ny, nx) for name, c in part.channels.items()}
    values = []
    for point in points:
        i, j, k = (int(v) for v in point.split(","))
        values.append({name: float(field[name][k, j, i]) for name in sorted(field)})
    print(json.dumps({
        "parts": names,
        "dims": [nx, ny, nz],
        "pose": [float(v) for v in header["volmap.pose"]],
        "machine": header["volmap.machine"],
        "channels": sorted(field),
        "dtype": str(np.asarray(field["VE.X"]).dtype),
        "values": values,
    }))

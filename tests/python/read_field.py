"""Reads a volmap field with the Python OpenEXR package, the way users do, and prints what it
found as JSON: the header attributes volmap writes and VE/OE at the requested grid points.

usage: read_field.py FIELD.exr i,j,k [i,j,k ...]
"""
import json
import sys

import numpy as np
import OpenEXR

path, points = sys.argv[1], sys.argv[2:]
with OpenEXR.File(path, separate_channels=True) as f:
    header = f.header()
    nx, ny, nz = (int(v) for v in header["volmap.dims"])
    channels = f.channels()
    # Pixel (i, j + k*ny) holds grid point (i, j, k): rows are y, columns x.
    field = {name: channels[name].pixels.reshape(nz, ny, nx) for name in channels}
    values = []
    for point in points:
        i, j, k = (int(v) for v in point.split(","))
        values.append({name: float(field[name][k, j, i]) for name in sorted(field)})
    print(json.dumps({
        "dims": [nx, ny, nz],
        "origin": [float(v) for v in header["volmap.origin"]],
        "spacing": [float(v) for v in header["volmap.spacing"]],
        "pose": [float(v) for v in header["volmap.pose"]],
        "machine": header["volmap.machine"],
        "chain": header["volmap.chain"],
        "channels": sorted(field),
        "dtype": str(np.asarray(field["VE.X"]).dtype),
        "compression": str(header["compression"]).split(".")[-1],
        "values": values,
    }))

"""Reads a VTK XML file volmap wrote (PolyData `.vtp` or ImageData `.vti`) with VTK's own
Python package, the reader ParaView uses, and prints what it found as JSON: the points (PolyData)
or the grid (ImageData), the cells, and every point data array with the active one.

usage: read_vtk.py FILE.vtp|FILE.vti
"""
import json
import sys

from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOXML import vtkXMLImageDataReader, vtkXMLPolyDataReader

path = sys.argv[1]
reader = vtkXMLPolyDataReader() if path.endswith(".vtp") else vtkXMLImageDataReader()
reader.SetFileName(path)
reader.Update()
if reader.GetErrorCode() != 0:
    sys.exit(f"VTK could not read {path}")
data = reader.GetOutput()
point_data = data.GetPointData()
arrays = {}
for n in range(point_data.GetNumberOfArrays()):
    array = point_data.GetArray(n)
    arrays[array.GetName()] = vtk_to_numpy(array).tolist()
active = point_data.GetScalars() or point_data.GetVectors()
out = {
    "points": data.GetNumberOfPoints(),
    "cells": data.GetNumberOfCells(),
    "arrays": arrays,
    "active": active.GetName() if active else None,
}
if path.endswith(".vtp"):
    out["coordinates"] = vtk_to_numpy(data.GetPoints().GetData()).tolist()
    out["polygons"] = [
        [data.GetCell(c).GetPointId(k) for k in range(data.GetCell(c).GetNumberOfPoints())]
        for c in range(data.GetNumberOfCells())
    ]
else:
    out["extent"] = list(data.GetExtent())
    out["origin"] = list(data.GetOrigin())
    out["spacing"] = list(data.GetSpacing())
print(json.dumps(out))

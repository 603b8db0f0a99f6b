"""Export of the groove walls for manufacturing: CSV (mm) and DXF (ezdxf, closed polylines in mm)."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from berryshaker.drives.groove_cam.kinematics import cam_groove
from berryshaker.drives.groove_cam.machine import GrooveCamMachine as Machine
from berryshaker.outputs import write_text_atomic


def groove_csv_text(machine: Machine, n: int = 721) -> str:
    """CSV with cam angle and the pitch, inner and outer wall coordinates (mm), one row per angle.

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description.
    n : int
        Number of cam angles over one revolution (the first repeated as the last).

    Returns
    -------
    str
        The CSV text: cam angle (deg), pitch, inner-wall and outer-wall x, y (mm).
    """
    phi, pitch, inner, outer = cam_groove(machine, n)
    buf = io.StringIO()
    buf.write("cam_angle_deg,pitch_x_mm,pitch_y_mm,inner_x_mm,inner_y_mm,outer_x_mm,outer_y_mm\n")
    data = np.column_stack([np.degrees(phi), pitch.T * 1e3, inner.T * 1e3, outer.T * 1e3])
    for row in data:
        buf.write(",".join(f"{v:.6f}" for v in row) + "\n")
    return buf.getvalue()


def write_groove_dxf(machine: Machine, path: str | Path, n: int = 1441) -> None:
    """DXF (R2010, units mm) with layers PITCH, INNER_WALL, OUTER_WALL as closed polylines.

    The duplicated end point (phi = 2 pi) is dropped and each polyline is flagged closed, so CAM
    software sees two closed contours ready for a pocketing toolpath.

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description.
    path : str or Path
        The DXF file to write (atomically; its folder is created).
    n : int
        Number of cam angles over one revolution.
    """
    import ezdxf
    from ezdxf import units

    phi, pitch, inner, outer = cam_groove(machine, n)
    doc = ezdxf.new("R2010")
    doc.units = units.MM
    msp = doc.modelspace()
    for layer, pts, color in (("PITCH", pitch, 8), ("INNER_WALL", inner, 1), ("OUTER_WALL", outer, 5)):
        doc.layers.add(layer, color=color)
        xy = (pts.T * 1e3)[:-1]
        msp.add_lwpolyline([tuple(p) for p in xy], close=True, dxfattribs={"layer": layer})
    msp.add_circle((0.0, 0.0), 1.0, dxfattribs={"layer": "PITCH"})  # cam centre mark
    text = io.StringIO()
    doc.write(text)  # R2010 writes UTF-8 text (what doc.saveas would put in the file)
    write_text_atomic(path, text.getvalue())


def write_groove_csv(machine: Machine, path: str | Path, n: int = 721) -> None:
    """Write the groove walls as CSV (cam angle in deg, pitch/inner/outer wall x, y in mm), atomically.

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description.
    path : str or Path
        The CSV file to write.
    n : int
        Number of cam angles over one revolution.
    """
    write_text_atomic(path, groove_csv_text(machine, n))

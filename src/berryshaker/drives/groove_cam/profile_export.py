"""Export of the groove walls for manufacturing: CSV (mm) and DXF (ezdxf, closed polylines in mm).

The walls are drawn at the groove's width on the drawing: the roller diameter plus the running clearance, at the
middle of the width's tolerance band, with the band's two limits beside them (``width``: the limits, the running
clearance and the tolerance, :class:`berryshaker.life.drawing.GrooveWidth` as ``cam-profile`` computes it).  Without
a width the walls are exactly one roller radius from the pitch curve.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from berryshaker.drives.groove_cam.kinematics import cam_groove
from berryshaker.drives.groove_cam.machine import GrooveCamMachine as Machine
from berryshaker.outputs import write_text_atomic


def _walls(machine: Machine, n: int, width):
    """Cam angles, pitch curve and the walls at the mean, smallest and largest width (m), each (2, n)."""
    from berryshaker.drives.groove_cam.kinematics import groove_profile_at
    from berryshaker.kinematics.cam import groove_profile

    phi, pitch, inner, outer = cam_groove(machine, n)
    if width is None:
        return phi, pitch, {"": (inner, outer)}
    svaj, s0, e = groove_profile_at(machine, phi)
    walls = {}
    for tag, w in (("", width.width_mean), ("_min", width.width_min), ("_max", width.width_max)):
        walls[tag] = groove_profile(phi, svaj[0], svaj[1], s0, e, w / 2.0)
    return phi, pitch, walls


def groove_csv_text(machine: Machine, n: int = 721, width=None) -> str:
    """CSV with cam angle and the pitch, inner and outer wall coordinates (mm), one row per angle.

    With a ``width``: the walls at the middle of the width's tolerance band, then the walls at its smallest and
    largest width (``inner_min_x_mm`` ...), and four constant columns that say the band and the running clearance
    (``width_min_mm``, ``width_max_mm``, ``running_clearance_min_mm``, ``running_clearance_max_mm``).

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description.
    n : int
        Number of cam angles over one revolution (the first repeated as the last).
    width : GrooveWidth, optional
        The groove width on the drawing (m; :func:`berryshaker.life.drawing.groove_width`).

    Returns
    -------
    str
        The CSV text: cam angle (deg), pitch, inner-wall and outer-wall x, y (mm) and, with a width, the band.
    """
    phi, pitch, walls = _walls(machine, n, width)
    cols = ["cam_angle_deg", "pitch_x_mm", "pitch_y_mm"]
    data = [np.degrees(phi), *(pitch * 1e3)]
    for tag, (inner, outer) in walls.items():
        cols += [f"inner{tag}_x_mm", f"inner{tag}_y_mm", f"outer{tag}_x_mm", f"outer{tag}_y_mm"]
        data += [*(inner * 1e3), *(outer * 1e3)]
    if width is not None:
        cols += ["width_min_mm", "width_max_mm", "running_clearance_min_mm", "running_clearance_max_mm"]
        data += [np.full(phi.size, v * 1e3) for v in (width.width_min, width.width_max, width.clearance_min,
                                                      width.clearance_max)]
    buf = io.StringIO()
    buf.write(",".join(cols) + "\n")
    for row in np.column_stack(data):
        buf.write(",".join(f"{v:.6f}" for v in row) + "\n")
    return buf.getvalue()


def write_groove_dxf(machine: Machine, path: str | Path, n: int = 1441, width=None) -> None:
    """DXF (R2010, units mm) with layers PITCH, INNER_WALL, OUTER_WALL as closed polylines.

    The duplicated end point (phi = 2 pi) is dropped and each polyline is flagged closed, so CAM
    software sees two closed contours ready for a pocketing toolpath.  With a ``width`` the walls are at the middle
    of its tolerance band, the band's limits are on layers INNER_WALL_MIN / OUTER_WALL_MIN (smallest width) and
    INNER_WALL_MAX / OUTER_WALL_MAX (largest), and a text on layer NOTES states the width, its tolerance and the
    running clearance.

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description.
    path : str or Path
        The DXF file to write (atomically; its folder is created).
    n : int
        Number of cam angles over one revolution.
    width : GrooveWidth, optional
        The groove width on the drawing (m; :func:`berryshaker.life.drawing.groove_width`).
    """
    import ezdxf
    from ezdxf import units

    phi, pitch, walls = _walls(machine, n, width)
    doc = ezdxf.new("R2010")
    doc.units = units.MM
    msp = doc.modelspace()
    layers = [("PITCH", pitch, 8)]
    for tag, (inner, outer) in walls.items():
        low = 3 if tag else 1
        layers += [(f"INNER_WALL{tag.upper()}", inner, low), (f"OUTER_WALL{tag.upper()}", outer, 5 if not tag else 4)]
    for layer, pts, color in layers:
        doc.layers.add(layer, color=color)
        xy = (pts.T * 1e3)[:-1]
        msp.add_lwpolyline([tuple(p) for p in xy], close=True, dxfattribs={"layer": layer})
    msp.add_circle((0.0, 0.0), 1.0, dxfattribs={"layer": "PITCH"})  # cam centre mark
    if width is not None:
        doc.layers.add("NOTES", color=7)
        top = float(np.max(walls[""][1][1]) * 1e3)
        msp.add_mtext(width.note(), dxfattribs={"layer": "NOTES", "char_height": 2.5, "width": 160.0,
                                                "insert": (float(np.min(walls[""][1][0]) * 1e3), top + 25.0)})
    text = io.StringIO()
    doc.write(text)  # R2010 writes UTF-8 text (what doc.saveas would put in the file)
    write_text_atomic(path, text.getvalue())


def write_groove_csv(machine: Machine, path: str | Path, n: int = 721, width=None) -> None:
    """Write the groove walls as CSV (:func:`groove_csv_text`: cam angle in deg, walls in mm), atomically.

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description.
    path : str or Path
        The CSV file to write.
    n : int
        Number of cam angles over one revolution.
    width : GrooveWidth, optional
        The groove width on the drawing (m).
    """
    write_text_atomic(path, groove_csv_text(machine, n, width))

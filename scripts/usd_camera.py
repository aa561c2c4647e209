"""Camera stages authored with Pixar's usd-core, and what usd-core reads back from them.

    python usd_camera.py OUTDIR

writes into OUTDIR, for each stage (Y-up as .usda, Z-up as .usdc, and the Y-up one again
zipped as .usdz):

  <name>.usd?        a camera under a transformed parent, animated over frames 1 to 3
                     (time samples at 1 and 3: frame 2 is interpolated), non-default
                     apertures and a lens shift
  <name>.json        per frame 0 to 4 (0 and 4 are outside the samples: held), what
                     usd-core reports: UsdGeom.Camera(prim).GetCamera(t) and the prim's
                     ComputeLocalToWorldTransform(t) (row-vector, row by row)
  <name>.chan        the same camera as a Nuke .chan (frame tx ty tz rx ry rz vfov, ZXY)
  <name>_chan.toml   a scene rendering the .chan with its film back as a [camera] table
                     (a .chan holds no gate) and the stage's up axis

tests/camera_files.rs reads them; run by /opt/murk-venv/bin/python (pip usd-core).
"""

import json
import math
import os
import sys

from pxr import Gf, Sdf, Usd, UsdGeom, UsdUtils

FRAMES = [0, 1, 2, 3, 4]
FILM = {
    "horizontalAperture": 24.0,
    "verticalAperture": 16.0,
    "horizontalApertureOffset": 1.5,
    "verticalApertureOffset": -0.8,
}


def author(path, up):
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, up)
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(3)
    world = UsdGeom.Xform.Define(stage, "/World")
    w = world.AddTranslateOp()
    w.Set(Gf.Vec3d(0.3, -0.2, 0.25))
    if up == UsdGeom.Tokens.z:
        # The same shot turned into a Z-up world: what was y is now z.
        world.AddRotateXOp().Set(90.0)
    rig = UsdGeom.Xform.Define(stage, "/World/Rig")
    rig.AddRotateYOp().Set(12.0)
    # A pivot, inverted after the rotation: composed as USD composes op stacks.
    pivot = rig.AddTranslateOp(opSuffix="pivot")
    pivot.Set(Gf.Vec3d(0.1, 0.0, -0.2))
    rig.AddScaleOp().Set(Gf.Vec3f(1.0, 1.0, 1.0))
    rig.AddTranslateOp(opSuffix="pivot", isInverseOp=True)
    cam = UsdGeom.Camera.Define(stage, "/World/Rig/Cam")
    t = cam.AddTranslateOp()
    r = cam.AddRotateXYZOp()
    t.Set(Gf.Vec3d(-0.4, 0.3, 7.0), 1)
    t.Set(Gf.Vec3d(0.9, 0.6, 6.2), 3)
    r.Set(Gf.Vec3f(-4.0, -6.0, 0.0), 1)
    r.Set(Gf.Vec3f(-8.0, 8.0, 5.0), 3)
    cam.GetFocalLengthAttr().Set(32.0, 1)
    cam.GetFocalLengthAttr().Set(40.0, 3)
    cam.GetHorizontalApertureAttr().Set(FILM["horizontalAperture"])
    cam.GetVerticalApertureAttr().Set(FILM["verticalAperture"])
    cam.GetHorizontalApertureOffsetAttr().Set(FILM["horizontalApertureOffset"])
    cam.GetVerticalApertureOffsetAttr().Set(FILM["verticalApertureOffset"])
    cam.GetClippingRangeAttr().Set(Gf.Vec2f(0.1, 1000.0))
    # A second prim that is not a camera, for --camera-prim's refusal.
    UsdGeom.Xform.Define(stage, "/World/NotACamera")
    stage.GetRootLayer().Save()
    return stage


def reference(stage):
    prim = stage.GetPrimAtPath("/World/Rig/Cam")
    cam = UsdGeom.Camera(prim)
    frames = []
    for f in FRAMES:
        g = cam.GetCamera(Usd.TimeCode(f))
        m = UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode(f))
        frames.append(
            {
                "frame": f,
                "focal_length": g.focalLength,
                "horizontal_aperture": g.horizontalAperture,
                "vertical_aperture": g.verticalAperture,
                "horizontal_offset": g.horizontalApertureOffset,
                "vertical_offset": g.verticalApertureOffset,
                "near": g.clippingRange.min,
                "far": g.clippingRange.max,
                "orthographic": g.projection == Gf.Camera.Orthographic,
                "local_to_world": [[m[i][j] for j in range(4)] for i in range(4)],
            }
        )
    return {
        "prim": "/World/Rig/Cam",
        "up_axis": UsdGeom.GetStageUpAxis(stage),
        "meters_per_unit": UsdGeom.GetStageMetersPerUnit(stage),
        "frames": frames,
    }


def zxy_degrees(m):
    """Euler angles (x, y, z) of the rotation of row-vector matrix m, turned z first,
    then x, then y (Nuke's ZXY): column-vector R = Ry·Rx·Rz."""
    # Column-vector rotation: the transpose of the row-vector matrix's 3×3.
    r = [[m[j][i] for j in range(3)] for i in range(3)]
    # R = Ry Rx Rz: r[1][2] = -sin(x).
    x = math.asin(max(-1.0, min(1.0, -r[1][2])))
    y = math.atan2(r[0][2], r[2][2])
    z = math.atan2(r[1][0], r[1][1])
    return [math.degrees(a) for a in (x, y, z)]


def write_chan(ref, path):
    lines = []
    for f in ref["frames"][1:4]:
        m = f["local_to_world"]
        rx, ry, rz = zxy_degrees(m)
        vfov = math.degrees(2 * math.atan(0.5 * f["vertical_aperture"] / f["focal_length"]))
        vals = [m[3][0], m[3][1], m[3][2], rx, ry, rz, vfov]
        lines.append("%d %s" % (f["frame"], " ".join(repr(v) for v in vals)))
    with open(path, "w") as out:
        out.write("\n".join(lines) + "\n")


def write_table(path, chan, vdb, up):
    with open(path, "w") as out:
        out.write('input = "%s"\ncamera_file = "%s"\nfilm_fit = "horizontal"\n' % (vdb, chan))
        # A .chan holds no up axis; the USD stage's sets murk's (and its default sun).
        out.write('up_axis = "%s"\n' % up.lower())
        out.write("[camera]\n")
        out.write("horizontal_aperture = %r\n" % FILM["horizontalAperture"])
        out.write("vertical_aperture = %r\n" % FILM["verticalAperture"])
        out.write("horizontal_aperture_offset = %r\n" % FILM["horizontalApertureOffset"])
        out.write("vertical_aperture_offset = %r\n" % FILM["verticalApertureOffset"])
        out.write("clipping_range = [0.1, 1000.0]\n")


def main():
    out = sys.argv[1]
    vdb = sys.argv[2] if len(sys.argv) > 2 else "cloud.vdb"
    os.makedirs(out, exist_ok=True)
    for name, up, ext in [("yup", UsdGeom.Tokens.y, "usda"), ("zup", UsdGeom.Tokens.z, "usdc")]:
        path = os.path.join(out, "%s.%s" % (name, ext))
        stage = author(path, up)
        ref = reference(stage)
        with open(os.path.join(out, name + ".json"), "w") as f:
            json.dump(ref, f, indent=1)
        write_chan(ref, os.path.join(out, name + ".chan"))
        write_table(os.path.join(out, name + "_chan.toml"), name + ".chan", vdb, up)
    ok = UsdUtils.CreateNewUsdzPackage(
        Sdf.AssetPath(os.path.join(out, "yup.usda")), os.path.join(out, "yup.usdz")
    )
    assert ok, "usdz"


if __name__ == "__main__":
    main()

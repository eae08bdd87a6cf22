"""Lights that are not surfaces, read from a scene description by the reference itself.

The tables (lrr's scene description syntax, read here with Python's `tomllib`, no lrr code):

    [[point_light]]        name, position, intensity = [r, g, b] W/sr
                           (or power = W with an optional colour: intensity = colour·power/4π)
    [[spot_light]]         name, position, direction (where it points), intensity = [r, g, b]
                           W/sr on the axis, inner_cone_deg = outer_cone_deg (half-angles from
                           the axis, glTF's innerConeAngle/outerConeAngle, in degrees)
    [[directional_light]]  name, direction (the direction light travels), irradiance = [r, g, b]
                           W per scene unit² on a plane facing the light
    [sky]                  radiance = [r, g, b]: uniform radiance from every direction

Units and what lrr means (exitance B = E + ρ·H + bounces, H the irradiance, all per scene
unit²) against what Mitsuba 3 means; they are the same, so values are passed as they are:
- point: H = I·cos θ/r². Mitsuba's `point` `intensity` is the radiant intensity (W/sr);
  its diffuse surface then reflects L_o = ρ/π · I·cos θ/r², and B = π·L_o = ρ·I·cos θ/r².
- spot: H = I·cos θ/r² inside the cone (angle to the axis ≤ outer_cone_deg), 0 outside.
  Mitsuba's `spot` `intensity` is the intensity on the axis (W/sr); its falloff is 1 up to
  `beam_width`, then LINEAR IN THE ANGLE down to 0 at `cutoff_angle` (both half-angles from the
  axis, degrees), and 0 beyond. glTF's falloff between inner and outer is instead
  clamp((cos α − cos outer)/(cos inner − cos outer))², so the two agree only for a hard cone,
  inner == outer: beam_width = cutoff_angle = outer_cone_deg (Mitsuba 3.9.1 evaluates that
  without dividing by zero: its 1/(cutoff − beam) is ∞ but only used on an empty set of
  angles; checked in scripts/reference/run.py's spot-square). A soft cone is refused here.
  Mitsuba's default beam_width is 3/4 of cutoff_angle: it is always given explicitly.
  The spot's local +z is turned onto `direction` by `look_at(position, position + direction)`.
- directional: H = E⊥·cos θ, E⊥ the irradiance on a plane facing the light. Mitsuba's
  `directional` `irradiance` is that E⊥ ("power per unit area received by a surface normal
  to the direction") and its `direction` is the travel direction: passed as they are (the
  direction normalised).
- sky: H = π·L on an unoccluded plane (a uniform sky over a hemisphere). Mitsuba's `constant`
  emitter `radiance` is that L (in the rgb variants, an `rgb` value is used as it is).

A description with `scale` (which multiplies coordinates) is refused with lights: what a scale
should do to an intensity or an irradiance is not settled here.
"""

import hashlib
import math
import tomllib

import numpy as np

TABLES = ("point_light", "spot_light", "directional_light", "sky")


def sha256(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def read(path):
    """The light tables of a description, as `tomllib` reads them ({} when it has none)."""
    with open(path, "rb") as f:
        doc = tomllib.load(f)
    lights = {k: doc[k] for k in TABLES if k in doc}
    if lights and doc.get("scale", 1.0) != 1.0:
        raise ValueError(f"{path}: lights in a scaled description (scale = {doc['scale']})")
    if lights and "include" in doc:
        raise ValueError(f"{path}: lights with [[include]] are not supported by the reference")
    return lights


def _rgb(v, what):
    v = [float(x) for x in v]
    if len(v) != 3 or not all(math.isfinite(x) and x >= 0.0 for x in v):
        raise ValueError(f"{what}: three finite values >= 0 expected, got {v}")
    return v


def _vec(v, what, unit=False):
    v = np.array([float(x) for x in v])
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{what}: three finite coordinates expected")
    if unit:
        n = np.linalg.norm(v)
        if n == 0.0:
            raise ValueError(f"{what}: a zero direction")
        v = v / n
    return v


def _keys(light, what, allowed):
    extra = set(light) - set(allowed)
    if extra:
        raise ValueError(f"{what}: unknown keys {sorted(extra)} (allowed: {sorted(allowed)})")


def normalised(lights):
    """Every light as plain numbers: [(kind, dict)] with intensity/irradiance/radiance RGB,
    unit directions, and the spot's cone (hard cones only)."""
    out = []
    for i, l in enumerate(lights.get("point_light", [])):
        what = f"point_light {l.get('name', i)}"
        _keys(l, what, {"name", "position", "intensity", "power", "colour", "group"})
        if "intensity" in l and "power" not in l and "colour" not in l:
            intensity = _rgb(l["intensity"], what)
        elif "power" in l and "intensity" not in l:
            c = _rgb(l.get("colour", [1.0, 1.0, 1.0]), what)
            intensity = [x * float(l["power"]) / (4.0 * math.pi) for x in c]
        else:
            raise ValueError(f"{what}: intensity, or power with an optional colour")
        out.append(("point", {"position": _vec(l["position"], what), "intensity": intensity}))
    for i, l in enumerate(lights.get("spot_light", [])):
        what = f"spot_light {l.get('name', i)}"
        _keys(l, what, {"name", "position", "direction", "intensity", "inner_cone_deg",
                        "outer_cone_deg", "group"})
        inner, outer = float(l["inner_cone_deg"]), float(l["outer_cone_deg"])
        if inner != outer:
            raise ValueError(
                f"{what}: inner_cone_deg {inner} != outer_cone_deg {outer}: glTF's falloff "
                "(squared, linear in cos) has no Mitsuba `spot` equivalent (linear in the angle)"
            )
        if not 0.0 < outer < 90.0:
            raise ValueError(f"{what}: a cone half-angle in (0, 90) degrees expected")
        out.append(("spot", {
            "position": _vec(l["position"], what),
            "direction": _vec(l["direction"], what, unit=True),
            "intensity": _rgb(l["intensity"], what),
            "cone_deg": outer,
        }))
    for i, l in enumerate(lights.get("directional_light", [])):
        what = f"directional_light {l.get('name', i)}"
        _keys(l, what, {"name", "direction", "irradiance", "group"})
        out.append(("directional", {
            "direction": _vec(l["direction"], what, unit=True),
            "irradiance": _rgb(l["irradiance"], what),
        }))
    if "sky" in lights:
        _keys(lights["sky"], "sky", {"radiance"})
        out.append(("sky", {"radiance": _rgb(lights["sky"]["radiance"], "sky")}))
    return out


def emitter_dicts(lights):
    """{id: Mitsuba emitter dict} of the lights, plain data (a spot's frame as `look_at`
    arguments): values passed as they are, see the module doc."""
    res = {}
    for n, (kind, l) in enumerate(normalised(lights)):
        if kind == "point":
            e = {"type": "point", "position": l["position"].tolist(),
                 "intensity": {"type": "rgb", "value": l["intensity"]}}
        elif kind == "spot":
            p, d = l["position"], l["direction"]
            # any up vector not parallel to the axis: look_at only needs it to build a frame
            up = np.eye(3)[int(np.argmin(np.abs(d)))]
            e = {
                "type": "spot",
                "intensity": {"type": "rgb", "value": l["intensity"]},
                "cutoff_angle": l["cone_deg"],
                "beam_width": l["cone_deg"],  # = cutoff: a hard cone, no linear ramp
                "look_at": {"origin": p.tolist(), "target": (p + d).tolist(), "up": up.tolist()},
            }
        elif kind == "directional":
            e = {"type": "directional", "direction": l["direction"].tolist(),
                 "irradiance": {"type": "rgb", "value": l["irradiance"]}}
        else:
            e = {"type": "constant", "radiance": {"type": "rgb", "value": l["radiance"]}}
        res[f"light{n}_{kind}"] = e
    return res


def emitters(mi, lights):
    """{id: Mitsuba emitter dict} ready for `mi.load_dict` (a spot's `look_at` as `to_world`)."""
    res = {}
    for k, e in emitter_dicts(lights).items():
        e = dict(e)
        if "look_at" in e:
            e["to_world"] = mi.ScalarTransform4f().look_at(**e.pop("look_at"))
        res[k] = e
    return res


def direct_irradiance(lights, positions, normals):
    """H per point and channel from the lights alone, nothing in the way (closed forms):
    point and spot I·cos θ/r² (spot: 0 beyond its cone), directional E⊥·max(0, −n·d),
    sky π·L (an unoccluded hemisphere: only right for a plane that sees nothing else)."""
    pos = np.asarray(positions, dtype=np.float64)
    nrm = np.asarray(normals, dtype=np.float64)
    h = np.zeros((len(pos), 3))
    for kind, l in normalised(lights):
        if kind in ("point", "spot"):
            v = l["position"] - pos
            r = np.linalg.norm(v, axis=1)
            cos = np.maximum(np.einsum("ij,ij->i", nrm, v) / r, 0.0)
            g = cos / (r * r)
            if kind == "spot":
                cos_axis = np.einsum("ij,j->i", -v, l["direction"]) / r
                g = np.where(cos_axis > math.cos(math.radians(l["cone_deg"])), g, 0.0)
            h += g[:, None] * np.array(l["intensity"])
        elif kind == "directional":
            cos = np.maximum(-nrm @ l["direction"], 0.0)
            h += cos[:, None] * np.array(l["irradiance"])
        else:
            h += math.pi * np.array(l["radiance"])
    return h

"""Mitsuba 3 BSDFs for brdfkit: measured MERL tables and any brdfkit model.

After :func:`register`, two plugins are known to ``mi.load_dict`` and scene XML:

``brdfkit_merl``
    A MERL binary table: ``filename`` (a path), ``interp`` (``"nearest"``, the
    reference lookup, or ``"linear"``).
``brdfkit_model``
    A brdfkit analytic model: ``json`` (the model description as JSON text) or
    ``filename`` (a model JSON file).

Both take ``sampling``: ``"lobe"`` (the default) or ``"cosine"``, and optionally
``lobe_fraction`` (the probability of sampling the lobe, in [0, 1]).

``eval`` is brdfkit's own f_r (the table lookup or the model, computed by the Rust
library) times the cosine of ``wo``, as Mitsuba's ``eval`` returns. ``sample`` draws
from a mixture: with probability ``lobe_fraction`` the half vector from a GGX lobe
whose roughness is that of a Cook-Torrance (GGX) model fitted once to the material at
load (Walter et al., "Microfacet Models for Refraction through Rough Surfaces", EGSR
2007, eqs. 33 and 35: the half vector with density D(h) cos θh, reflected, so the
direction's density is D(h) cos θh / (4 |wo·h|)), else a cosine-weighted direction
(density cos θo / π). ``pdf`` is the same mixture density, so ``sample`` and ``pdf``
agree (the chi² test) and ``eval / pdf`` is the weight ``sample`` returns.

In the JIT variants (``llvm_ad_rgb``) the BSDF is evaluated once per wavefront: the
lanes are copied to NumPy, brdfkit evaluates them all in one call (in parallel, the
GIL released) and the result goes back as one array. That needs evaluated loops and
calls, which :func:`register` switches on (``dr.JitFlag.SymbolicLoops`` and
``dr.JitFlag.SymbolicCalls`` off). The scalar variants call brdfkit once per ray.
"""

from __future__ import annotations

import json
import os

import numpy as np

import brdfkit

__all__ = ["register", "fitted_lobe"]

# Fitted sampling lobes by (file, size, mtime) or model JSON: a plugin is instantiated
# once per scene load, and Mitsuba's chi² adapter instantiates it on every call.
_LOBES: dict = {}

# Dims the lobe of a model is fitted on (a coarse table: the lobe only guides sampling).
_LOBE_DIMS = (45, 45, 90)


def _mean(v) -> float:
    """The mean of a number, an RGB list, or the numbers of a nested dict."""
    if isinstance(v, dict):
        return float(np.mean([_mean(x) for x in v.values()]))
    return float(np.mean(v))


def fitted_lobe(source: brdfkit.MerlTable | brdfkit.Model) -> tuple[float, float]:
    """(GGX alpha, lobe fraction) of the sampling lobe of a table or a model.

    A Cook-Torrance model with the GGX distribution is fitted to the table (one
    start, the cbrt loss; a model is first tabulated on a coarse grid). The alpha is
    its roughness; the lobe fraction is its specular share, mean ρs / (mean ρs + mean
    ρd), kept within [0.1, 0.9] so that neither strategy is ever left out.
    """
    table = source if isinstance(source, brdfkit.MerlTable) else brdfkit.resample(source, _LOBE_DIMS)
    r = brdfkit.fit(table, "cook-torrance", starts=1, distribution="ggx")
    p = r.model.params
    alpha = min(max(_mean(p["alpha"]), 1e-3), 1.0)
    rs, rd = _mean(p["rho_s"]), _mean(p["rho_d"])
    frac = rs / (rs + rd) if rs + rd > 0 else 0.5
    return alpha, min(max(frac, 0.1), 0.9)


def _lobe_of(key, make_source):
    if key not in _LOBES:
        _LOBES[key] = fitted_lobe(make_source())
    return _LOBES[key]


def _class(mi, dr):
    """The BSDF class for the current variant."""

    def rows(v) -> np.ndarray:
        """A Mitsuba vector (one, or a wavefront of them) as an (N, 3) float64 array of
        unit vectors: brdfkit takes unit directions only (within 1e-6), and Mitsuba's
        are float32, so each is renormalised in float64; a lane that is not a
        direction (zero or non-finite: an inactive lane) becomes the normal, and its
        value is masked out by the caller's ``active``."""
        a = np.stack(
            [np.atleast_1d(np.asarray(c, dtype=np.float64)) for c in (v.x, v.y, v.z)],
            axis=1,
        )
        n = np.linalg.norm(a, axis=1, keepdims=True)
        ok = np.isfinite(n) & (n > 0)
        return np.where(ok, a / np.where(ok, n, 1.0), np.array([0.0, 0.0, 1.0]))

    class BrdfkitBSDF(mi.BSDF):
        """A brdfkit table or model as a Mitsuba BSDF (module docstring)."""

        def __init__(self, props, evaluate, lobe, label):
            mi.BSDF.__init__(self, props)
            self._evaluate = evaluate
            self._label = label
            sampling = props.get("sampling", "lobe")
            if sampling not in ("lobe", "cosine"):
                raise ValueError(f"{label}: sampling `{sampling}`: expected \"lobe\" or \"cosine\"")
            alpha, frac = lobe() if sampling == "lobe" else (0.5, 0.0)
            if "lobe_fraction" in props:
                frac = float(props["lobe_fraction"])
                if not 0.0 <= frac <= 1.0:
                    raise ValueError(f"{label}: lobe_fraction {frac} is outside [0, 1]")
            self.alpha, self.lobe_fraction = alpha, frac
            self._distr = mi.MicrofacetDistribution(mi.MicrofacetType.GGX, alpha, False)
            flags = (
                mi.BSDFFlags.GlossyReflection
                | mi.BSDFFlags.DiffuseReflection
                | mi.BSDFFlags.FrontSide
            )
            self.m_components = [flags]
            self.m_flags = flags

        def _f(self, wi, wo, active):
            """f_r · cos θo: brdfkit's values for every lane in one call."""
            a, b = rows(wi), rows(wo)
            if len(a) != len(b):  # one side broadcast (a single wi against many wo)
                n = max(len(a), len(b))
                a, b = (np.ascontiguousarray(np.broadcast_to(x, (n, 3))) for x in (a, b))
            f = np.nan_to_num(self._evaluate(a, b), nan=0.0)
            f = mi.Color3f(f.T.astype(np.float32)) if dr.is_jit_v(mi.Float) else mi.Color3f(*map(float, f[0]))
            cos_o = mi.Frame3f.cos_theta(wo)
            ok = active & (mi.Frame3f.cos_theta(wi) > 0) & (cos_o > 0)
            return dr.select(ok, f * cos_o, 0.0)

        def _pdf(self, wi, wo, active):
            """The mixture density of ``wo`` (module docstring)."""
            cos_o = mi.Frame3f.cos_theta(wo)
            h = dr.normalize(wi + wo)
            spec = self._distr.pdf(wi, h) / (4.0 * dr.abs_dot(wo, h))
            cos = mi.warp.square_to_cosine_hemisphere_pdf(wo)
            p = self.lobe_fraction * spec + (1.0 - self.lobe_fraction) * cos
            ok = active & (mi.Frame3f.cos_theta(wi) > 0) & (cos_o > 0)
            return dr.select(ok, p, 0.0)

        def eval(self, ctx, si, wo, active=True):
            return self._f(si.wi, wo, active)

        def pdf(self, ctx, si, wo, active=True):
            return self._pdf(si.wi, wo, active)

        def eval_pdf(self, ctx, si, wo, active=True):
            return self._f(si.wi, wo, active), self._pdf(si.wi, wo, active)

        def sample(self, ctx, si, sample1, sample2, active=True):
            wi = si.wi
            use_lobe = sample1 < self.lobe_fraction
            h, _ = self._distr.sample(wi, sample2)
            wo = dr.select(use_lobe, mi.reflect(wi, h), mi.warp.square_to_cosine_hemisphere(sample2))
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = wo
            bs.pdf = self._pdf(wi, wo, active)
            bs.eta = 1.0
            bs.sampled_type = dr.select(
                use_lobe,
                mi.UInt32(+mi.BSDFFlags.GlossyReflection),
                mi.UInt32(+mi.BSDFFlags.DiffuseReflection),
            )
            bs.sampled_component = mi.UInt32(0)
            value = self._f(wi, wo, active)
            ok = active & (bs.pdf > 0)
            return bs, dr.select(ok, value / dr.select(ok, bs.pdf, 1.0), 0.0)

        def traverse(self, callback):
            pass

        def to_string(self):
            return (
                f"BrdfkitBSDF[{self._label}, lobe alpha={self.alpha:.4g}, "
                f"lobe fraction={self.lobe_fraction:.3g}]"
            )

    return BrdfkitBSDF


def _merl(cls, props):
    if "filename" not in props:
        raise ValueError("brdfkit_merl: `filename` (a MERL binary table) is required")
    path = str(props["filename"])
    interp = props.get("interp", "nearest")
    table = brdfkit.MerlTable.read(path)
    table.lookup(np.zeros((0, 3)), np.zeros((0, 3)), interp)  # checks `interp` at load
    st = os.stat(path)
    key = ("table", os.path.abspath(path), st.st_size, st.st_mtime_ns)
    return cls(
        props,
        lambda wi, wo: table.lookup(wi, wo, interp),
        lambda: _lobe_of(key, lambda: table),
        f"brdfkit_merl {path} ({interp})",
    )


def _model(cls, props):
    if "json" in props:
        text = str(props["json"])
    elif "filename" in props:
        with open(str(props["filename"]), encoding="utf-8") as f:
            text = f.read()
    else:
        raise ValueError("brdfkit_model: `json` (a model description) or `filename` is required")
    model = brdfkit.Model.from_json(text)
    key = ("model", model.to_json())
    return cls(props, model.eval, lambda: _lobe_of(key, lambda: model), f"brdfkit_model {model.name}")


def register() -> None:
    """Registers ``brdfkit_merl`` and ``brdfkit_model`` with Mitsuba's current variant.

    Call it after ``mi.set_variant(...)`` (and again after changing the variant). In
    JIT variants it turns symbolic loops and calls off (module docstring).
    """
    import drjit as dr
    import mitsuba as mi

    if mi.variant() is None:
        raise RuntimeError("brdfkit.mitsuba.register(): call mi.set_variant(...) first")
    if dr.is_jit_v(mi.Float):
        dr.set_flag(dr.JitFlag.SymbolicLoops, False)
        dr.set_flag(dr.JitFlag.SymbolicCalls, False)
    cls = _class(mi, dr)
    mi.register_bsdf("brdfkit_merl", lambda props: _merl(cls, props))
    mi.register_bsdf("brdfkit_model", lambda props: _model(cls, props))

#!/usr/bin/python3
"""Fits the confidence model of src/verify/confidence_model.cpp to pcl_mi_compare CSVs (one per
set, named by the file name) and checks it out of sample, each set left out in turn.

The model is a logistic regression of "within the success bound" on five terms of the
evidence: normalised MI, weakest contrast, logit of the inlier fraction, log(1 + inliers)
and peak contrast. Every set weighs the same, whatever its number of results, and a small
ridge keeps the weights finite where a set separates perfectly. The verdict it is scored
with is the engine's: search converged, at least 30 inliers, free-direction contrast at
least 0.05 and confidence at least THRESHOLD (kReliableConfidence).

With -weights W1,...,W5 the five weights are kept (the model's, in the order above) and
only the intercept is fitted: a recalibration after a change of the engine moved the
results, which keeps what the weights learnt about unrelated scenes.

With -below_threshold B0,W1,...,W5 the model (intercept and weights) is kept and only the
logit z below logit(THRESHOLD) is recalibrated, to a * z + b, fitted over the pooled
results below the threshold (each result weighs the same, as in the reliability
diagram); every verdict stays as it is. It prints a and b and the reliability diagram
in sample and with each set left out.

With -lead B0,W1,...,W5 the model is kept and the lead term of a narrow view is fitted:
WL * clamp(lead, LEAD_CLAMP) + BL added to the logit of the results with a lead (the CSVs'
last column, NaN for 360-degree views), by logistic regression over those results; it
prints WL and BL and the verdict in sample and with each set left out.

With -calibration B0,W1,...,W5[,WL,BL] the model is kept too (with its lead term), and the
logit z below logit(THRESHOLD) goes through a monotone piecewise-linear map with knots at
CALIBRATION_KNOTS (the map of src/verify/confidence_model.cpp): its ends stay where they are,
and the values at the inner knots are a logistic regression of success on the map's hat
functions, fitted over the pooled results (each result weighs the same, as in the
reliability diagram), penalised for bends and for straying from the identity. Every verdict
stays as it is. Refused results that restarts of the refinement found unsteady (the CSVs'
restart columns; src/engine/steadiness.cpp), degenerate results that leave the sensors in
place (the reason says so; src/verify/verification.cpp) and results the clouds swapped
were asked to confirm (the reverse columns set; src/engine/reverse_confirmation.cpp) take a
fixed confidence instead and stay out of the fit; the script prints how many of them
were right. A set named "unrelated"
(scripts/unrelated_pairs.py) takes part in the fit and is left out of the acceptance
diagram; its mean confidence is printed.

Usage: fit_confidence.py [-success T,R]
                         [-weights W1,...,W5 | -below_threshold B0,W1,...,W5 |
                          -lead B0,W1,...,W5 | -calibration B0,W1,...,W5[,WL,BL]]
                         A.csv B.csv ...
"""
import csv
import os
import sys

import numpy as np

TERMS = ["normalized_mi", "weakest_contrast", "logit(inlier_fraction)", "log1p(inliers)",
         "peak_contrast"]
RIDGE = 0.1
THRESHOLD = 0.95
# The calibration's knots in the logit; the last is logit(THRESHOLD), above which it keeps z.
CALIBRATION_KNOTS = np.array([-5.0, -3.0, -2.0, -1.0, 0.0, 1.0, 2.0,
                              np.log(THRESHOLD / (1.0 - THRESHOLD))])
# The fit's penalties: on the change of slope from knot to knot, and on the distance from
# the identity.
CALIBRATION_SMOOTHNESS = 0.3
CALIBRATION_RIDGE = 1.0
# The lead's clamp (src/verify/confidence_model.cpp).
LEAD_CLAMP = (-0.3, 0.5)
# A refused result whose restarts of the refinement end this far apart or farther (degrees,
# metres; src/engine/steadiness.cpp) is unsteady and takes this confidence
# (kUnsteadyConfidence, src/verify/verification.h).
STEADY_LIMITS = (1.0, 0.25)
UNSTEADY_CONFIDENCE = 0.06
# A steady result refused as degenerate whose reason says this takes this confidence
# (kInPlaceDegenerateConfidence, src/verify/verification.h).
IN_PLACE_REASON = "leaves the sensors where they were"
IN_PLACE_CONFIDENCE = 0.04
# A result the alignment of the clouds swapped confirmed takes this confidence
# (kReverseConfirmedConfidence, src/verify/verification.h).
REVERSE_CONFIRMED_CONFIDENCE = 0.99
# One it did not confirm (the reverse columns set, not converged) takes this
# (kReverseUnconfirmedConfidence).
REVERSE_UNCONFIRMED_CONFIDENCE = 0.77


def passes_gate(row):
    """The verdict's tests other than the confidence, from one CSV row: search converged,
    at least 30 inliers, free-direction contrast at least 0.05. Free turns that the MI or the
    refinement holds pass the library's test but not this one, nor do results the clouds
    swapped confirm, so the gate is stricter."""
    return (row["search_converged"] == "1" and int(row["inliers"]) >= 30 and
            float(row["free_direction_contrast"]) >= 0.05)


def load(path, bound):
    with open(path) as f:
        rows = [r for r in csv.DictReader(f) if r["method"].startswith("mi-")]
    g = lambda k: np.array([float(r[k]) for r in rows])
    f = np.clip(g("inlier_fraction"), 1e-3, 1 - 1e-3)
    x = np.column_stack([g("normalized_mi"), g("weakest_contrast"), np.log(f / (1 - f)),
                         np.log1p(g("inliers")), g("peak_contrast")])
    y = (g("translation_error_m") < bound[0]) & (g("rotation_error_deg") < bound[1])
    gate = np.array([passes_gate(r) for r in rows], dtype=bool)
    return x, y, gate


def load_lead(path):
    """The lead column of the MI rows of \a path; NaN where a row or the file has none."""
    with open(path) as f:
        rows = [r for r in csv.DictReader(f) if r["method"].startswith("mi-")]
    return np.array([float(r.get("lead") or "nan") for r in rows])


def load_fixed(path):
    """Per MI row of \a path, the fixed confidence it takes: UNSTEADY_CONFIDENCE for a refused
    result its restarts found unsteady, IN_PLACE_CONFIDENCE for another degenerate one that
    leaves the sensors in place, REVERSE_CONFIRMED_CONFIDENCE or
    REVERSE_UNCONFIRMED_CONFIDENCE for one the clouds swapped confirmed or did not, NaN for
    the rest (and where the file has no such columns)."""
    with open(path) as f:
        rows = [r for r in csv.DictReader(f) if r["method"].startswith("mi-")]
    spread = lambda r, k: float(r.get(k) or "nan")

    def fixed(r):
        if not np.isnan(spread(r, "reverse_shift_m")):
            return (REVERSE_CONFIRMED_CONFIDENCE if r["converged"] == "1" else
                    REVERSE_UNCONFIRMED_CONFIDENCE)
        if (r["converged"] == "0" and not np.isnan(spread(r, "restart_turn_deg")) and
                not (spread(r, "restart_turn_deg") < STEADY_LIMITS[0] and
                     spread(r, "restart_shift_m") < STEADY_LIMITS[1])):
            return UNSTEADY_CONFIDENCE
        if r.get("refusal") == "degenerate" and IN_PLACE_REASON in r.get("reason", ""):
            return IN_PLACE_CONFIDENCE
        return np.nan
    return np.array([fixed(r) for r in rows])


def logit_of(model, x, lead):
    """The model's logit; with a lead term (model of 8 values), added where a lead exists."""
    z = model[0] + x @ model[1:6]
    if len(model) == 8:
        has = ~np.isnan(lead)
        z = z + np.where(has, model[6] * np.clip(np.nan_to_num(lead), *LEAD_CLAMP) + model[7], 0.0)
    return z


def fit_lead(z, lead, y):
    """WL, BL of the logistic regression of y on z + WL * clamp(lead) + BL."""
    x1 = np.column_stack([np.clip(lead, *LEAD_CLAMP), np.ones(len(lead))])
    b = np.zeros(2)
    for _ in range(100):
        p = 1.0 / (1.0 + np.exp(-(z + x1 @ b)))
        step = np.linalg.solve((x1 * (p * (1 - p))[:, None]).T @ x1 + 1e-9 * np.eye(2),
                               x1.T @ (p - y))
        b -= step
        if np.abs(step).max() < 1e-10:
            break
    return b


def lead_term(sets, leads, model):
    """The -lead mode."""
    z = {n: logit_of(model, sets[n][0], leads[n]) for n in sets}
    narrow = [n for n in sets if (~np.isnan(leads[n])).any()]

    def fitted(names):
        has = [~np.isnan(leads[n]) for n in names]
        return fit_lead(np.concatenate([z[n][h] for n, h in zip(names, has)]),
                        np.concatenate([leads[n][h] for n, h in zip(names, has)]),
                        np.concatenate([sets[n][1][h] for n, h in zip(names, has)]).astype(float))

    def verdict(title, terms):
        totals = np.zeros(4)
        for n in sets:
            p = 1.0 / (1.0 + np.exp(-logit_of(np.r_[model, terms[n]], sets[n][0], leads[n])))
            y, said = sets[n][1], sets[n][2] & (p >= THRESHOLD)
            totals += [said.sum(), (said & ~y).sum(), (said & y).sum(), y.sum()]
            if n in narrow:
                wrong, found = (said & ~y).sum(), (said & y).sum()
                print("  %-24s %5d converged, %3d wrong (%.2f %%), recall %5.1f %%" % (
                    n, said.sum(), wrong, 100.0 * wrong / max(said.sum(), 1),
                    100.0 * found / max(y.sum(), 1)))
        print("%s, all sets: %d converged, %d wrong (%.2f %%), recall %.1f %%" % (
            title, totals[0], totals[1], 100.0 * totals[1] / max(totals[0], 1),
            100.0 * totals[2] / max(totals[3], 1)))

    b = fitted(narrow)
    print("lead weight %.2f, offset %.2f" % (b[0], b[1]))
    verdict("Without the lead term", {n: np.array([0.0, 0.0]) for n in sets})
    verdict("In sample", {n: b for n in sets})
    held_out = {n: fitted([m for m in narrow if m != n]) if n in narrow else b for n in sets}
    for n in narrow:
        print("  fitted without %s: %.2f, %.2f" % (n, held_out[n][0], held_out[n][1]))
    verdict("Each set left out", held_out)
    return 0


def fit_intercept(x, y, w, weights):
    z, c = x @ weights, 0.0
    for _ in range(100):
        p = 1.0 / (1.0 + np.exp(-(z + c)))
        # Newton's step, bounded: a set the intercept alone separates saturates p.
        step = np.clip((w * (p - y)).sum() / max((w * p * (1 - p)).sum(), 1e-9), -1.0, 1.0)
        c -= step
        if abs(step) < 1e-12:
            break
    return np.r_[c, weights]


def fit(x, y, w):
    x1 = np.column_stack([np.ones(len(x)), x])
    b = np.zeros(x1.shape[1])
    ridge = RIDGE * np.diag(np.r_[0.0, np.ones(x.shape[1])])
    for _ in range(100):
        p = 1.0 / (1.0 + np.exp(-x1 @ b))
        step = np.linalg.solve((x1 * (w * p * (1 - p))[:, None]).T @ x1 + ridge,
                               x1.T @ (w * (p - y)) + ridge @ b)
        b -= step
        if np.abs(step).max() < 1e-10:
            break
    return b


def predict(b, x):
    return 1.0 / (1.0 + np.exp(-(b[0] + x @ b[1:])))


def fit_below_threshold(z, y):
    """a, b of the logistic fit of y on a * z + b over the results with z below the
    threshold's logit."""
    below = z < np.log(THRESHOLD / (1.0 - THRESHOLD))
    x1 = np.column_stack([z[below], np.ones(below.sum())])
    b = np.array([1.0, 0.0])
    for _ in range(100):
        p = 1.0 / (1.0 + np.exp(-x1 @ b))
        step = np.linalg.solve((x1 * (p * (1 - p))[:, None]).T @ x1, x1.T @ (p - y[below]))
        b -= step
        if np.abs(step).max() < 1e-10:
            break
    return b


def recalibrated(ab, z):
    z0 = np.log(THRESHOLD / (1.0 - THRESHOLD))
    return 1.0 / (1.0 + np.exp(-np.where(z < z0, ab[0] * z + ab[1], z)))


def print_reliability(title, p, y):
    print("\n%s: decile, rows, observed success - mean confidence (points)" % title)
    for k in range(10):
        m = (p >= k / 10.0) & ((p < (k + 1) / 10.0) if k < 9 else (p <= 1.0))
        if m.any():
            print("  %.1f-%.1f %5d %+6.1f" % (k / 10.0, (k + 1) / 10.0, m.sum(),
                                              100.0 * (y[m].mean() - p[m].mean())))


def recalibrate(sets, model):
    """The -below_threshold mode."""
    z = {n: model[0] + sets[n][0] @ model[1:] for n in sets}
    y = {n: sets[n][1].astype(float) for n in sets}
    ab = fit_below_threshold(np.concatenate(list(z.values())), np.concatenate(list(y.values())))
    print("below the threshold: z -> %.3f * z + %.3f" % (ab[0], ab[1]))
    pooled = np.concatenate(list(z.values()))
    print_reliability("In sample", recalibrated(ab, pooled), np.concatenate(list(y.values())))
    held_out = []
    for name in sets:
        others = [n for n in sets if n != name]
        ab_others = fit_below_threshold(np.concatenate([z[n] for n in others]),
                                        np.concatenate([y[n] for n in others]))
        held_out.append(recalibrated(ab_others, z[name]))
    print_reliability("Each set left out", np.concatenate(held_out),
                      np.concatenate(list(y.values())))
    return 0


def hat_basis(z):
    """Per z (inside the knots' span), the weights of the knot values in the interpolation."""
    k = CALIBRATION_KNOTS
    basis = np.zeros((len(z), len(k)))
    i = np.clip(np.searchsorted(k, z, side="right") - 1, 0, len(k) - 2)
    t = (z - k[i]) / (k[i + 1] - k[i])
    basis[np.arange(len(z)), i] = 1.0 - t
    basis[np.arange(len(z)), i + 1] = t
    return basis


def calibrate(values, z):
    """The map: identity outside the knots' span, linear between the knots' values."""
    k = CALIBRATION_KNOTS
    return np.where((z < k[0]) | (z >= k[-1]), z, np.interp(z, k, values))


def fit_calibration(z, y):
    """The inner knots' values by ridge-regularised logistic regression (IRLS); the ends are
    the knots themselves."""
    k = CALIBRATION_KNOTS
    inside = (z >= k[0]) & (z < k[-1])
    basis, y = hat_basis(z[inside]), y[inside]
    offset = basis[:, 0] * k[0] + basis[:, -1] * k[-1]
    a = basis[:, 1:-1]
    v = k[1:-1].copy()
    # The penalty: the slopes' changes from knot to knot (a smooth map), as a quadratic form
    # in the full value vector, of which the inner values are free.
    n = len(k)
    slopes = np.zeros((n - 1, n))
    for i in range(n - 1):
        slopes[i, i], slopes[i, i + 1] = -1.0 / (k[i + 1] - k[i]), 1.0 / (k[i + 1] - k[i])
    bends = slopes[1:] - slopes[:-1]
    penalty = CALIBRATION_SMOOTHNESS * bends.T @ bends + CALIBRATION_RIDGE * np.eye(n)
    inner = penalty[1:-1, 1:-1]
    for _ in range(100):
        p = 1.0 / (1.0 + np.exp(-(a @ v + offset)))
        full = np.r_[k[0], v, k[-1]]
        gradient = (penalty @ (full - k))[1:-1]
        step = np.linalg.solve((a * (p * (1 - p))[:, None]).T @ a + inner,
                               a.T @ (p - y) + gradient)
        v -= step
        if np.abs(step).max() < 1e-10:
            break
    values = np.r_[k[0], v, k[-1]]
    if np.any(np.diff(values) <= 0.0):
        print("warning: the fitted map is not monotone: %s" % np.round(values, 3))
    return values


def calibration(sets, leads, fixed, model):
    """The -calibration mode. The results with a fixed confidence (load_fixed()) take it and
    stay out of the fit."""
    has_fixed = {n: ~np.isnan(fixed[n]) for n in fixed}
    # z: the fitted results' logits; y: every result's success.
    z = {n: logit_of(model, sets[n][0], leads[n])[~has_fixed[n]] for n in sets}
    y = {n: sets[n][1].astype(float) for n in sets}
    values = fit_calibration(np.concatenate(list(z.values())),
                             np.concatenate([y[n][~has_fixed[n]] for n in sets]))
    print("knots  " + " ".join("%6.2f" % v for v in CALIBRATION_KNOTS))
    print("values " + " ".join("%6.2f" % v for v in values))
    accepted = [n for n in sets if n != "unrelated"]
    for names, title in ((accepted, "the sets"), (["unrelated"], "unrelated")):
        for value, kind in ((UNSTEADY_CONFIDENCE, "unsteady"),
                            (IN_PLACE_CONFIDENCE, "degenerate in place"),
                            (REVERSE_CONFIRMED_CONFIDENCE, "confirmed by the clouds swapped"),
                            (REVERSE_UNCONFIRMED_CONFIDENCE, "not confirmed by them")):
            u = np.concatenate([sets[n][1][fixed[n] == value] for n in names if n in sets] or
                               [[]])
            print("%s results (%s): %d, right %d (confidence %.2f)" % (
                kind, title, len(u), int(np.sum(u)), value))

    def p(names, f):
        out = []
        for n in names:
            q = fixed[n].copy()
            q[~has_fixed[n]] = 1.0 / (1.0 + np.exp(-f(n, z[n])))
            out.append(q)
        return np.concatenate(out)
    y_accepted = np.concatenate([y[n] for n in accepted])
    print_reliability("Before", p(accepted, lambda n, v: v), y_accepted)
    print_reliability("In sample", p(accepted, lambda n, v: calibrate(values, v)), y_accepted)
    held_out = {}
    for name in sets:
        others = [n for n in sets if n != name]
        held_out[name] = fit_calibration(
            np.concatenate([z[n] for n in others]),
            np.concatenate([y[n][~has_fixed[n]] for n in others]))
    print_reliability("Each set left out",
                      p(accepted, lambda n, v: calibrate(held_out[n], v)), y_accepted)
    if "unrelated" in sets:
        for title, f in (("before", lambda n, v: v),
                         ("in sample", lambda n, v: calibrate(values, v)),
                         ("left out", lambda n, v: calibrate(held_out[n], v))):
            q = p(["unrelated"], f)
            print("unrelated, %s: mean confidence %.3f, median %.3f, most %.3f" % (
                title, q.mean(), np.median(q), q.max()))
    return 0


def main(argv):
    args, files, bound = argv[1:], [], (0.5, 2.0)
    weights = model = None
    mode = None
    while len(args) >= 2 and args[0] in ("-success", "-weights", "-below_threshold",
                                         "-lead", "-calibration"):
        values = tuple(float(v) for v in args[1].split(","))
        if args[0] == "-success":
            bound = values
        elif args[0] == "-weights":
            weights = np.array(values)
        else:
            model, mode = np.array(values), args[0]
        args = args[2:]
    if mode in ("-lead", "-calibration"):
        name = lambda p: os.path.splitext(os.path.basename(p))[0]
        sets = {name(p): load(p, bound) for p in args}
        leads = {name(p): load_lead(p) for p in args}
        if mode == "-lead":
            return lead_term(sets, leads, model)
        return calibration(sets, leads, {name(p): load_fixed(p) for p in args}, model)
    if model is not None:
        return recalibrate({os.path.splitext(os.path.basename(p))[0]: load(p, bound)
                            for p in args}, model)
    fitter = fit if weights is None else lambda x, y, w: fit_intercept(x, y, w, weights)
    sets = {os.path.splitext(os.path.basename(p))[0]: load(p, bound) for p in args}

    def pooled(names):
        x = np.vstack([sets[n][0] for n in names])
        y = np.concatenate([sets[n][1] for n in names]).astype(float)
        w = np.concatenate([np.full(len(sets[n][1]), 1000.0 / len(sets[n][1])) for n in names])
        return x, y, w

    x, y, w = pooled(list(sets))
    b = fitter(x, y, w)
    print("intercept %.2f" % b[0])
    for name, weight in zip(TERMS, b[1:]):
        print("%-24s %.2f" % (name, weight))
    y = y > 0.5
    gate = np.concatenate([sets[n][2] for n in sets])
    said = gate & (predict(b, x) >= THRESHOLD)
    print("\nIn sample: %d converged, %d wrong among them (%.2f %%), recall %.1f %%" % (
        said.sum(), (said & ~y).sum(), 100.0 * (said & ~y).sum() / max(said.sum(), 1),
        100.0 * (said & y).sum() / max(y.sum(), 1)))
    print("\nLeft out in turn (fitted on the others): converged, wrong among them, recall")
    totals = np.zeros(4)
    for name in sets:
        others = [n for n in sets if n != name]
        x, y, gate = sets[name]
        said = gate & (predict(fitter(*pooled(others)), x) >= THRESHOLD)
        totals += [said.sum(), (said & ~y).sum(), (said & y).sum(), y.sum()]
        print("%-24s %5d %4d (%4.1f %%) %5.1f %%" % (name, said.sum(), (said & ~y).sum(),
              100.0 * (said & ~y).sum() / max(said.sum(), 1), 100.0 * (said & y).sum() / max(y.sum(), 1)))
    print("%-24s %5d %4d (%4.2f %%) %5.1f %%" % ("all", totals[0], totals[1],
          100.0 * totals[1] / max(totals[0], 1), 100.0 * totals[2] / max(totals[3], 1)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

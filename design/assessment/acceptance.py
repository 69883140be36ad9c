"""The acceptance checks of a designed controller, run by ``bridgeflap optimise`` and
:func:`bridgeflap.design.assessment.accept.accept`.

A controller is judged on the bridges it was not designed on (the brief's "do no harm"), with
its flaps failed and its actuators limited, and its exported plant is re-closed by an
independent path. :func:`acceptance` runs, for one controller and its design card:

``robustness``
    :func:`bridgeflap.design.assessment.harm.do_no_harm`: ``samples`` fresh variants of the card's
    bridge over the estimated-input ranges, each variant's closed-loop critical speed against its
    own open-loop one (fraction stable to the design speed, fraction harmed, worst ratio,
    per-variant rows).
``failures``
    :func:`bridgeflap.design.assessment.failsafe.single_pair_failures`: each single flap pair stuck
    (at 0 and at an angle) and the controller off, on the card's bridge.
``actuators``
    :func:`bridgeflap.design.assessment.actuator_study.actuator_study`: the closed loop in
    Monte-Carlo turbulence with the card's flap angle and rate limits at 10, 20, 25 m/s and 0.95 of
    the closed-loop critical speed (RMS and peak angle and rate, fraction of time saturated).
``independent_check``
    :func:`independent_check`: the controller *as read back from its file* closed around the
    exported open-loop plant (:func:`bridgeflap.model.aeroelastic.control_plant.plant_data`, flap
    inputs) by a plain feedback formula here, against the design's own closed loop: the eigenvalues
    at a few speeds agree to :data:`EIGENVALUE_RTOL`.
``usable_speed``
    :func:`bridgeflap.design.assessment.usable_speed.usable_speed`: the highest speed at which the
    controller does what its linear design promises with the card's actuators, in the bridge's
    design turbulence: the lowest of the linear closed-loop critical speed (ideal actuators), the
    speeds where the 3 sigma flap angle or rate reaches its limit (spectral) and the speed up to
    which the saturated loop holds (bisection with the Monte-Carlo simulation of the actuator
    check, its record length and seed), with the limit that binds; and the open-loop critical
    speed it must exceed (:func:`~bridgeflap.design.assessment.usable_speed.usable_speed_verdict`).

Each check reports its own ``status``; the block's ``status`` is ``passed`` when the independent
check agrees, the controller harms no variant and its usable speed is above the open-loop
critical speed, ``harm`` when it lowers some variant's critical speed below its open-loop one
(whatever else is unresolved), ``failed`` when the independent check disagrees or the usable
speed is not above the open-loop critical speed (``reason`` says which), ``unresolved``
otherwise (a crossing not verified). The fresh
variants are independent uniform draws (``sampling = "random"``, seed 11: none is a design
scenario), so the robustness block carries a one-sided 95 % Clopper-Pearson upper bound on the
probability of harm (``harm_probability_upper_95``: 0.30 % for 0 harmed of 1000). The fraction
stable to the design speed, the failure and the fixed-speed actuator verdicts are reported, not
folded into the status: they are properties of the bridge and the flap authority as much as of
the design (the GJ range of the uncertainty set alone puts 12.5 % of the variants beyond any 3
m-flap controller's reach, ``runs/robust_limit``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from bridgeflap.model.errors import BridgeflapError, BridgeflapInputError

__all__ = ["CHECKS", "EIGENVALUE_RTOL", "AcceptanceOptions", "acceptance", "design_closed_loop",
           "acceptance_text", "independent_check", "parse_checks"]

#: the checks, in the order they run (cheapest first)
CHECKS = ("independent_check", "robustness", "failures", "actuators", "usable_speed")
#: the eigenvalues of the two closed loops agree to this, relative to max(1, |lambda|) [-]:
#: the required 1e-6. Both are eigenvalues of the same matrix up to a change of state
#: coordinates (the plant's beta'' elimination), so rounding bounds the difference by
#: ~1e-13 for simple eigenvalues; the repeated RFA lag poles are defective clusters whose
#: members are known only to ~sqrt(eps) = 1.5e-8 (each cluster's mean to rounding), so the
#: members are matched one to one and 1e-6 holds with a factor 60 to spare.
EIGENVALUE_RTOL = 1e-6
#: speeds of the independent check, as fractions of the design speed (plus 0 m/s)
CHECK_SPEED_FRACTIONS = (0.0, 0.25, 0.5, 0.75, 1.0)


@dataclass(frozen=True)
class AcceptanceOptions:
    """Sizes of the checks (``bridgeflap optimise --checks/--check-samples``; ``quick``: the
    CI sizes of ``--quick``)."""

    checks: tuple = CHECKS
    samples: int = 1000
    seed: int = 11
    #: independent uniform draws: the Clopper-Pearson certificate needs them
    sampling: str = "random"
    workers: int = 1
    actuator_speeds_m_s: tuple = (10.0, 20.0, 25.0)
    actuator_records: int = 4
    actuator_duration_s: float = 600.0
    actuator_modes: int = 16
    quick: bool = False

    @classmethod
    def for_quick(cls, checks=CHECKS, workers: int = 1, samples: int | None = None):
        """The ``--quick`` sizes: 8 variants, one 60 s record per speed."""
        return cls(checks=tuple(checks), samples=8 if samples is None else int(samples),
                   workers=workers, actuator_records=1, actuator_duration_s=60.0, quick=True)


def parse_checks(text: str) -> tuple:
    """``"all"``, ``"none"`` or a comma list of :data:`CHECKS` (``--checks``)."""
    t = str(text).strip().lower()
    if t == "all":
        return CHECKS
    if t == "none":
        return ()
    names = tuple(dict.fromkeys(p.strip().replace("-", "_") for p in t.split(",") if p.strip()))
    bad = [n for n in names if n not in CHECKS]
    if bad or not names:
        raise BridgeflapInputError("checks", f"expected all, none or a comma list of "
                                   f"{', '.join(CHECKS)}; got {text!r}")
    return tuple(n for n in CHECKS if n in names)


def design_closed_loop(result, settings):
    """The design's own closed-loop system on ``settings.verification_modes`` modes and the
    candidate's flap layout (the one its report sweeps; built here when the design did not
    keep it)."""
    cl = result.extras.get("closed_loop")
    if cl is None:
        from bridgeflap.design.control.formulation.problem_model import build_model

        _, model = build_model(settings, n_modes=settings.verification_modes,
                               positions=result.candidate.flap_strip_positions_m)
        cl = model.system(result.candidate.compensator)
    return cl


def _match_rel(a: np.ndarray, b: np.ndarray) -> float:
    """Largest |a_i - b_p(i)| / max(1, |a_i|) over the one-to-one matching of least total
    distance (Hungarian assignment)."""
    from scipy.optimize import linear_sum_assignment

    d = np.abs(a[:, None] - b[None, :])
    i, j = linear_sum_assignment(d)
    return float(np.max(d[i, j] / np.maximum(1.0, np.abs(a[i]))))


def _independent_loop(spec, controller, speed, n_modes, system):
    """``A`` of the exported flap plant closed through ``controller`` (positive feedback: the
    drives are +-K(s) of each flap's pitch), by the general feedthrough formula."""
    from bridgeflap.model.aeroelastic.control_plant import plant_data

    p = plant_data(spec, speed, inputs="flaps", n_modes=n_modes, controller=controller,
                   system=system)
    Ac, Bc, Cc, Dc = controller.compensator.state_space()
    nf = controller.n_flaps
    signs = [s for s, on in ((1.0, controller.trailing_edge), (-1.0, controller.leading_edge))
             if on]
    eye = np.eye(nf)
    AK, BK = np.kron(eye, Ac), np.kron(eye, Bc)
    CK = np.vstack([s * np.kron(eye, Cc) for s in signs])
    DK = np.vstack([s * np.kron(eye, Dc) for s in signs])
    rows = [i for i, n in enumerate(p.output_names) if n.startswith("pitch_flap[")]
    Cp, Dp = p.C[rows], p.D[rows]
    # y = Cp x + Dp u, u = CK xc + DK y  =>  y = M (Cp x + Dp CK xc), M = (I - Dp DK)^-1
    M = np.linalg.inv(np.eye(len(rows)) - Dp @ DK)
    top = np.hstack([p.A + p.B @ DK @ M @ Cp, p.B @ (CK + DK @ M @ Dp @ CK)])
    bottom = np.hstack([BK @ M @ Cp, AK + BK @ M @ Dp @ CK])
    return np.vstack([top, bottom])


def independent_check(controller, settings, closed_loop, speeds=None, bridge=None) -> dict:
    """The design's closed-loop eigenvalues against an independent closing of its exported
    plant (module docstring), at ``speeds`` [m/s] (default :data:`CHECK_SPEED_FRACTIONS` of the
    design speed)."""
    from bridgeflap.model.aeroelastic import statespace
    from bridgeflap.model.structure.fe import assemble
    from bridgeflap.model.structure.loader import load_bridge
    from bridgeflap.model.structure.modes import solve

    spec = load_bridge(settings.bridge if bridge is None else bridge)
    n = int(settings.verification_modes)  # the modes of design_closed_loop
    system = statespace.spec_system(spec, solve(assemble(spec)).structural_basis(n))
    u = ([f * settings.speed_max_m_s for f in CHECK_SPEED_FRACTIONS] if speeds is None
         else [float(x) for x in speeds])
    rows = []
    for U in u:
        own = np.linalg.eigvals(closed_loop.A(U))
        ind = np.linalg.eigvals(_independent_loop(spec, controller, U, n, system))
        same = own.size == ind.size
        rel = _match_rel(own, ind) if same else None
        rows.append({"speed_m_s": U, "states": int(own.size), "independent_states":
                     int(ind.size), "eigenvalue_difference_rel": rel,
                     "max_real_part_1_s": float(own.real.max()),
                     "independent_max_real_part_1_s": float(ind.real.max())})
    worst = max((r["eigenvalue_difference_rel"] for r in rows
                 if r["eigenvalue_difference_rel"] is not None), default=None)
    ok = all(r["eigenvalue_difference_rel"] is not None
             and r["eigenvalue_difference_rel"] <= EIGENVALUE_RTOL for r in rows)
    return {"status": "agrees" if ok else "disagrees", "modes": n,
            "tolerance_rel": EIGENVALUE_RTOL, "largest_difference_rel": worst,
            "method": "controller.toml read back, closed around "
                      "bridgeflap.model.aeroelastic.control_plant.plant_data"
                      " (flap inputs) by the feedthrough formula; eigenvalues matched one to "
                      "one (Hungarian) against the design's closed loop",
            "speeds": rows}


def _robustness(controller, settings, opts, say, bridge):
    from bridgeflap.design.assessment.harm import do_no_harm

    res = do_no_harm(controller, bridge, count=opts.samples, seed=opts.seed,
                     n_modes=settings.fresh_variant_modes,
                     speed_max_m_s=settings.speed_max_m_s, workers=opts.workers, progress=say,
                     sampling=opts.sampling)
    return res, {**res.summary(), "rows": [dict(r) for r in res.rows]}


def _failures(controller, settings, opts, say, bridge):
    from bridgeflap.design.assessment.failsafe import single_pair_failures

    res = single_pair_failures(controller, bridge,
                               n_modes=settings.verification_modes,
                               speed_max_m_s=settings.speed_max_m_s, workers=opts.workers,
                               progress=say)
    return res, res.summary()


def _actuators(controller, settings, opts, say, bridge):
    from bridgeflap.design.assessment.actuator_study import actuator_study
    from bridgeflap.model.aeroelastic.actuator_limits import ActuatorLimits
    from bridgeflap.model.structure.loader import load_bridge

    limits = ActuatorLimits(settings.flap_angle_limit_deg, settings.flap_rate_limit_deg_s)
    res = actuator_study(load_bridge(bridge), controller, opts.actuator_speeds_m_s,
                         limits, duration_s=opts.actuator_duration_s,
                         records=opts.actuator_records, n_modes=opts.actuator_modes,
                         progress=say)
    return res, {**res.summary(), "limits_from": "design card"}


def _usable_speed(controller, settings, opts, say, bridge, limits=None):
    from bridgeflap.design.assessment.usable_speed import usable_speed
    from bridgeflap.design.control.review.checks import closed_loop_limits
    from bridgeflap.model.aeroelastic.actuator_limits import ActuatorLimits
    from bridgeflap.model.structure.loader import load_bridge

    spec = load_bridge(bridge)
    if not limits or "governing_speed_m_s" not in limits:
        # the linear closed- and open-loop critical speeds of the verification model
        limits = closed_loop_limits(settings, controller, spec)
    open_loop = min((v for v in (limits.get("open_loop_flutter_speed_m_s"),
                                 limits.get("open_loop_divergence_speed_m_s"))
                     if isinstance(v, float) and v == v), default=float("nan"))
    act = ActuatorLimits(settings.flap_angle_limit_deg, settings.flap_rate_limit_deg_s)
    res = usable_speed(spec, controller, act,
                       linear_critical_m_s=limits.get("governing_speed_m_s"),
                       open_loop_critical_m_s=open_loop, n_modes=opts.actuator_modes,
                       records=opts.actuator_records, duration_s=opts.actuator_duration_s,
                       response_step_m_s=8.0 if opts.quick else 4.0, progress=say)
    return res, {**res.summary(), "critical_speeds_modes": limits.get("modes"),
                 "limits_from": "design card"}


def acceptance(controller, settings, options: AcceptanceOptions | None = None, *,
               closed_loop=None, progress=None, bridge=None,
               closed_loop_limits=None) -> tuple[dict, dict]:
    """Run the checks of ``options`` on ``controller`` designed with ``settings``.

    Returns ``(block, results)``: the strict-JSON-ready block (module docstring) and the
    result objects by check name (for their tables). ``closed_loop``: the design's own
    closed-loop system, needed by the independent check (skipped without it). A check that
    meets a :class:`~bridgeflap.model.errors.BridgeflapError` (e.g. flutter-derivative decks have no
    actuator simulation) reports ``status: "error"`` with the reason. ``bridge``: the bridge
    the controller was designed for (a spec, name or path; default ``settings.bridge``).
    ``closed_loop_limits``: the design's own closed- and open-loop limits
    (:func:`bridgeflap.design.control.review.checks.closed_loop_limits`; computed when not given).
    """
    opts = AcceptanceOptions() if options is None else options
    say = progress or (lambda _msg: None)
    bridge = settings.bridge if bridge is None else bridge
    block, results = {"checks": list(opts.checks)}, {}
    runners = {"robustness": _robustness, "failures": _failures, "actuators": _actuators,
               "usable_speed": lambda *a: _usable_speed(*a, limits=closed_loop_limits)}
    for name in opts.checks:
        t0 = time.perf_counter()
        say(f"acceptance: {name} ({CHECKS.index(name) + 1}/{len(CHECKS)}) ...")
        try:
            if name == "independent_check":
                if closed_loop is None:
                    block[name] = {"status": "skipped", "reason": "no design closed loop"}
                    continue
                block[name] = independent_check(controller, settings, closed_loop,
                                                bridge=bridge)
            else:
                results[name], block[name] = runners[name](controller, settings, opts, say,
                                                           bridge)
        except BridgeflapInputError:
            raise
        except BridgeflapError as exc:
            block[name] = {"status": "error", "reason": str(exc)}
        block[name]["elapsed_s"] = time.perf_counter() - t0
        say(f"acceptance: {name}: {block[name]['status']} "
            f"({block[name]['elapsed_s']:.0f} s)")
    block["status"] = _verdict(block)
    reasons = _failure_reasons(block)
    if reasons:
        block["reason"] = "; ".join(reasons)
    return block, results


def _failure_reasons(block: dict) -> list:
    """What fails, one phrase per failed check (the block's ``reason``)."""
    out = []
    if block.get("independent_check", {}).get("status") == "disagrees":
        out.append("the independent closed loop disagrees")
    us = block.get("usable_speed", {})
    if us.get("status") == "not_above_open_loop":
        out.append(f"{us['reason']} (limited by {us.get('usable_speed_limited_by')})")
    return out


def _verdict(block: dict) -> str:
    ind = block.get("independent_check", {}).get("status")
    rob = block.get("robustness", {}).get("status")
    use = block.get("usable_speed", {}).get("status")
    if ind == "disagrees":
        return "failed"
    if rob == "harm":
        return "harm"
    if use == "not_above_open_loop":
        return "failed"
    if ind in (None, "agrees", "skipped") and rob in (None, "no_harm"):
        return "passed" if (ind or rob or use) else "not_run"
    return "unresolved"


#: What the acceptance verdict means, printed under it (``acceptance_text``).
VERDICT_MEANING = {
    "passed": "passed = the independent closed loop agrees, the controller lowers no fresh "
              "variant's critical speed below its open-loop one, and its usable speed with the "
              "actuator limits is above the open-loop critical speed; the stable fraction, the "
              "failed-pair and the fixed-speed actuator lines below are reported, not part of "
              "the verdict",
    "harm": "harm = the controller lowers some fresh variant's critical speed below its "
            "open-loop one: not usable",
    "failed": "failed = the independent closed loop disagrees with the design's, or the usable "
              "speed with the actuator limits is not above the open-loop critical speed: not "
              "usable",
    "unresolved": "unresolved = a fresh variant's crossing could not be verified: not usable",
}


def acceptance_text(acc: dict) -> str:
    """One line per check of the acceptance block."""
    def f(v, spec):
        return "n/a" if v is None else format(v, spec)

    out = [f"acceptance: {acc['status']}" + (f": {acc['reason']}" if acc.get("reason")
                                               else "")]
    u = acc.get("usable_speed")
    if u and "usable_speed_m_s" in u:
        sims = u.get("saturated_loop_simulations") or []
        out.append(f"  usable speed: {f(u['usable_speed_m_s'], '.1f')} m/s, limited by "
                   f"{u.get('usable_speed_limited_by')}, against the open-loop critical speed "
                   f"{f(u.get('open_loop_critical_speed_m_s'), '.1f')} m/s (linear closed-loop "
                   f"critical speed (ideal actuators) "
                   f"{f(u.get('linear_closed_loop_critical_speed_m_s'), '.2f')} m/s; 3 sigma "
                   f"flap angle at {u.get('flap_angle_limit_deg'):g} deg from "
                   f"{f(u.get('flap_angle_3sigma_speed_m_s'), '.1f')} m/s, rate at "
                   f"{u.get('flap_rate_limit_deg_s'):g} deg/s from "
                   f"{f(u.get('flap_rate_3sigma_speed_m_s'), '.1f')} m/s; saturated loop holds "
                   f"to {f(u.get('saturated_loop_holds_to_m_s'), '.1f')} m/s, "
                   f"{len(sims)} simulations of {u.get('records')} x "
                   f"{u.get('duration_s'):g} s): {u['status']}")
    meaning = VERDICT_MEANING.get(acc.get("status"))
    if meaning:
        out.append(f"  ({meaning})")
    ind = acc.get("independent_check")
    if ind and "largest_difference_rel" in ind:
        out.append(f"  independent closed loop ({ind['modes']} modes, {len(ind['speeds'])} "
                   f"speeds): eigenvalues agree to {f(ind['largest_difference_rel'], '.2e')} "
                   f"(tolerance {ind['tolerance_rel']:g}): {ind['status']}")
    r = acc.get("robustness")
    if r and "variants" in r:
        out.append(f"  do no harm: {r['variants']} fresh variants, "
                   f"{100 * r['fraction_stable_to_design_speed']:.1f} % stable to "
                   f"{r['design_speed_m_s']:g} m/s, {r.get('harmed_count', '?')} harmed "
                   f"({100 * r['fraction_harmed']:.1f} %; 95 % upper bound on the harm "
                   f"probability {f(r.get('harm_probability_upper_95'), '.2%')}), "
                   f"{r['unresolved_variants']} unresolved, worst closed/open "
                   f"{f(r['worst_closed_over_open'], '.4f')}: {r['status']}")
    fl = acc.get("failures")
    if fl and "worst_single_failure" in fl:
        w = fl["worst_single_failure"]
        out.append(f"  one pair failed: worst {f(w.get('critical_speed_m_s'), '.2f')} m/s "
                   f"(pair {w.get('pair')}), controller off "
                   f"{f(fl['controller_off']['critical_speed_m_s'], '.2f')} m/s, "
                   f"{fl['pairs_stable_to_design_speed']}/{fl['flap_pairs']} pairs stable to "
                   f"{fl['design_speed_m_s']:g} m/s: {fl['status']}")
    a = acc.get("actuators")
    if a and "speeds" in a:
        parts = [f"{s['speed_m_s']:.1f} m/s " + (
            f"rms {s['rms_flap_angle_deg']:.2f} deg, peak {s['peak_flap_angle_deg']:.2f} deg, "
            f"saturated {100 * s['angle_saturated_fraction']:.2f} %" if s["status"] == "ok"
            else s["status"]) for s in a["speeds"]]
        out.append(f"  actuators: {'; '.join(parts)}: {a['status']}; the saturated loop "
                   f"holds to {f(a.get('saturated_loop_holds_to_m_s'), '.1f')} m/s of those "
                   f"checked (linear closed-loop critical speed "
                   f"{f(a.get('closed_loop_critical_speed_m_s'), '.2f')} m/s)")
    for name in ("independent_check", "robustness", "failures", "actuators", "usable_speed"):
        c = acc.get(name) or {}
        if c.get("status") in ("error", "skipped"):
            out.append(f"  {name}: {c['status']} ({c.get('reason')})")
    return "\n".join(out)

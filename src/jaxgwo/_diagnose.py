r"""Sim-to-real gap diagnosis: *where* the paper model departs from flight data, *which*
unmodelled effect causes it, and *how far* the held-out gap shrinks once it is added.

1. **Nominal**: the paper model (eqs. 15-16) identified on the TRAIN records by the main
   pipeline (:func:`jaxgwo._identify.identify_channels`); the VAL records are held out.
2. **Where** (:mod:`jaxgwo._diagnose_where`): frequency bands outside the random-error
   bounds, residual whiteness and input-residual correlation on VAL, amplitude dependence
   between low- and high-amplitude TRAIN data, coherence loss.
3. **Which** (:mod:`jaxgwo._diagnose_which`): every effect of the vocabulary added,
   refitted and scored on VAL; ``none`` when no candidate beats noise.  When the best one
   is a ``structural_mode`` with real zeros, a pole pair the paper model lacks rather than
   a resonance, it is a *structure* finding: refitted in a wider damping box, kept, and
   the effects ranked again on top of it (``DiagnoseSettings.structure_zeta_z``), a
   ``structural_mode`` among them as a lightly damped resonance beside that pair, which
   is then held fixed (:attr:`jaxgwo._diagnose_which.ModelSpec.fixed_modes`).  When
   the best one is a ``time_delay``, such a mode is looked for on top of the delay too
   (a long delay hides it from the paper-model ranking).  A ``structural_mode`` whose pole
   damping is far above the vocabulary's (a broad pair) is no resonance: on top it goes to
   the structure step, and where that keeps no structure it beats noise no more.
4. **How far**: the top candidate, and the top two combined, before and after.

:func:`diagnose` returns a :class:`Diagnosis`; :meth:`Diagnosis.to_json` is the stable
report of issue 5, :meth:`Diagnosis.summary` the plain-language one.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np

from ._data import ATTITUDE_COLUMNS, CHANNELS, FlightRecord
from ._diagnose_where import (
    AmplitudeDependence,
    FrequencyMismatch,
    GyroPath,
    ResidualTests,
    amplitude_dependence,
    frequency_mismatch,
    gyro_path,
    noise_limited_bands,
    residual_tests,
)
from ._diagnose_which import (
    _FLAP_LO_TIME_DOMAIN_S,
    _Z_HI,
    _Z_HI_STRUCTURE,
    _Z_LO,
    _Z_LO_STRUCTURE,
    _Z_NEUTRAL,
    AIRFRAME_LAGS,
    FREQUENCY_DOMAIN,
    NONLINEAR,
    AugmentedCifer,
    CandidateScore,
    LinearFit,
    ModelSpec,
    TimeFit,
    _active_mask,
    _flipped_objective,
    airframe_lag_refit,
    bracketed_lag,
    delay_aware_start,
    effect_params_from_z,
    f_test_p,
    fit_cross_coupling,
    fit_linear_candidates,
    fit_nonlinear_candidates,
    held_out_centred,
    held_out_fit,
    j_evidence,
    j_f_test_p,
    j_worse_p,
    joint_pair_resonance_scan,
    matched_filter_p,
    matched_filter_z,
    nonlinearity_acts,
    output_error_evidence,
    refit_linear_time_domain,
    score_candidate,
    simulate_model,
    simulated_response_cost,
    with_fixed_modes,
)
from ._effects import EFFECTS
from ._identify import (
    IdentifySettings,
    _need_int,
    _prepare,
    channel_signals,
    identify_channels,
    independent_points,
)

__all__ = ["DIAGNOSE_STAGES", "DiagnoseSettings", "Diagnosis", "TimeDomainRefit", "diagnose", "SEPARATING_EXCITATION",
           "separation_suggestion"]

REFIT_MARGIN_R2 = 1e-3
"""Held-out R^2 difference below which the summary counts the null refit and another model
as level: the summary quotes R^2 to 3 decimals."""

_AIRFRAME_COUPLING_NOTE = (
    "The gain counts every path from the off-axis stick into this axis as mixing ahead of the servo, the "
    "airframe's own included: a rotor whose flapping the other cyclic drives directly (the R-50's B_lon, 0.099 of "
    "B_lat in the published model) adds its share. On the blind study's R-50 variants the gain read "
    "above the mixing drawn on 19 of 22 cases (median 0.037 above; from 0.122 below to 0.119 above)."
)
"""The summary's caveat beside a ``cross_coupling`` verdict.  The R-50's lateral flapping
equation has ``B_lat delta_lat + B_lon delta_lon``, exactly a mixing of the longitudinal
stick at ``B_lon / B_lat`` on that path, beside the paths through the longitudinal flapping.
Measured on the stored diagnoses of fresh seeds 311, 313, 317 and 331, then out of sample
on 337 and 347 (``docs/diagnosis-record.md``, session 54): the seventeen R-50 coupling
cases' gains lie +0.005 to +0.119 above the drawn gain, the 31 paper plants' on both sides
of it.  Seed 349, drawn after that (session 55), adds two R-50 couplings at +0.030 and
-0.014, the first below; seeds 353 and 359 (session 56) add -0.021, -0.122 and +0.084."""

SEPARATING_EXCITATION = {  # each a clause that ends the report's "explain the data almost equally well; ..."
    frozenset({"sensor_lag", "rotor_flapping"}): (
        "no cyclic excitation separates them: with the paper parameters refitted, a gyro filter and an in-loop "
        "flapping lag give the same input-output response (each is K over a stable cubic times the "
        "servo), so they differ only in what the gyro sees of disturbances; read the gyro filter's "
        "cutoff from the autopilot's parameters, or log the attitude estimate beside the rate (columns phi, "
        "theta): the gyro path then tells them apart"
    ),
    frozenset({"time_delay", "sensor_lag"}): (
        "to separate them: a delay keeps the magnitude flat while a gyro filter rolls it off: extend the sweep above the "
        "filter cutoff (15-20 Hz) with good coherence"
    ),
    frozenset({"time_delay", "rotor_flapping"}): (
        "to separate them: extend the sweep beyond the rotor/fuselage mode, where an in-loop lag changes the magnitude "
        "and a delay does not"
    ),
    frozenset({"rate_limit", "saturation"}): (
        "to separate them: fly sweeps at two or three amplitudes: a rate limit bites at high frequency, a saturation at "
        "large amplitude at any frequency"
    ),
    frozenset({"rate_limit", "backlash"}): (
        "to separate them: a small-amplitude sweep: backlash dominates small inputs, a rate limit large fast ones"
    ),
    frozenset({"backlash", "saturation"}): (
        "to separate them: sweeps at two clearly different amplitudes: backlash hurts small inputs, saturation large ones"
    ),
}


@dataclass(frozen=True)
class DiagnoseSettings:
    r"""What shapes a diagnosis.

    The defaults are the configuration the blind study validates and its thresholds were
    set on (``benchmarks/blind_diagnosis.py`` without ``--quick`` runs ``DiagnoseSettings()``;
    ``jaxgwo diagnose`` too, unless told otherwise).  A larger search is not a better
    calibrated one: the thresholds below were set on these sizes of the nominal fit and
    the refits (80 analysis frequencies, 12 wolves, 30 iterations, 40 polish steps).

    ``identify``: settings of the nominal identification (and of the frequency response the
    linear candidates are refitted on).  ``wolves`` / ``iterations``: the candidate refit's
    IGWO; ``nonlinear_wolves`` / ``nonlinear_iterations`` the nonlinear candidates' packs,
    ``nonlinear_profile_points``, ``nonlinear_refine_rows`` and ``nonlinear_polish_steps``
    their profile, Levenberg-Marquardt and L-BFGS-B budgets
    (:func:`jaxgwo._diagnose_which.fit_nonlinear_candidates`'s ``profile_points``,
    ``refine_rows``, ``polish_steps``): those fits take most of a diagnosis's time, and the
    test suite runs them smaller.  A candidate beats noise when its identification
    evidence passes a test at level ``alpha`` and the held-out records do not contradict
    it: the block z-score of its
    held-out squared-error reduction exceeds ``z_min`` and it closes more than ``min_gap``
    of the R^2 gap (:func:`jaxgwo._diagnose_which.score_candidate`).  The time-domain
    candidates (nonlinear, cross-coupling), whose identification evidence is an output
    error with strongly correlated residuals, must also be confirmed on the held-out
    records: z-score above ``z_min_time`` and a positive gap (for a nonlinear one whose
    evidence passes at ``alpha`` with the effect size, the gap its own null refit leaves
    may stand in for the nominal's: :func:`jaxgwo._diagnose_which.score_candidate`'s
    ``gap_against_baseline``).  So must a linear candidate
    that passes not on ``J`` but on its time-domain check (its output-error refit against
    the null refit, F-test at ``alpha`` without the nonlinear effect size), which counts
    where no linear candidate passes on ``J``, or where ``J`` finds this one but its ``J``
    fit fails the held-out check (:func:`_takes_time_domain_path`); a resonance that ``J``
    and the matched filter both find on the identification records needs the held-out
    records only not to contradict its refit (:func:`_same_resonance`).  A ``structural_mode`` must
    close a positive gap as well: its three shape parameters can fit a local bump of the
    identification response's estimate, which the ``J`` F-test takes for evidence (seed-41
    development cases: a none case fitted one at p = 1e-4 that lowered the held-out R^2;
    every true mode found raised it), unless its ``J`` fit is a resonance ``J`` finds on its
    own evidence (:func:`_resonance_found_by_j`: the held-out multisteps hardly excite the
    vocabulary's band, and two true R-50 resonances lowered it).  A nonlinear one must also
    cut the null refit's identification output error by the factor ``min_error_ratio``
    (an effect size: without it a mild clipping fits gust-induced error significantly),
    unless the held-out records' BIC improves over the null refit's by ``held_out_bic``
    where the nonlinearity acts on them (their effect size, :func:`_effect_size_passes`;
    2, the edge of "positive" evidence on Kass and Raftery's scale) or the amplitude test of
    step 2 independently shows the change with amplitude that this nonlinearity predicts;
    with the amplitude test's backing its output-error F-test need only pass at
    ``alpha_amplitude``.  One that cuts
    that error by ``strong_error_ratio`` or more needs
    the held-out records only not to contradict it (``z_min``, as a linear candidate):
    held-out multisteps may reach a limit seldom (set on seed 2's nonlinear cases, whose
    effect-free refits cut the error by at most 1.004).  So does one the amplitude test
    backs whose output-error F-test passes at ``alpha`` itself (:func:`_amplitude_backed`:
    two independent tests of the identification records).  The same holds for a
    ``cross_coupling`` (its gain's test in place of the F-test): held-out multisteps with
    little off-axis activity confirm a real coupling weakly (seed-31 case_053: gain -0.22,
    error cut x1.67, held-out z 0.67, refused before), and on the stored rankings of
    development seeds 2, 7, 11, 23, 31 and 41 no cross-coupling fitted to a case without one
    cut the error by more than x1.16.  On top of a structure finding,
    whose pole pair a nonlinearity refits beside it
    (:func:`jaxgwo._diagnose_which.fit_nonlinear_candidates`' ``free_mode``) where its
    pair-held fit does not beat noise, a nonlinear candidate's effect size is the amplitude
    test's backing or a cut of ``pair_free_error_ratio`` (:func:`_pair_free_effect_size`),
    and no longer ``min_error_ratio``, the held-out BIC or ``J``: the pair's freedom lets a
    nonlinearity take up the airframe's model-form error, on the identification and the
    held-out records alike.  On the 22 R-50 ``none`` cases with a structure finding of the
    stored draws 311-359 the best cut x1.06, and three passed on the cut or the held-out
    BIC (x1.05-1.06); fresh seed 367's case_039 passed on ``J`` (0.38 of the null's).  Of
    ten R-50 rate limits answered ``none`` or otherwise before, seven are found: six with
    the amplitude test's backing, one on a cut of x1.11.  Set there, in sample.  Either
    way its ``J`` must be no worse than the pair-free null's: two wrong names of the path
    fitted ``J`` 1.27-1.54 times the null's, its right finds 0.19-0.58 times (session 58,
    in sample).  Where both fits beat noise, the pair-free one is the model where its
    refitted pair cuts the held fit's identification error at ``alpha``
    (:func:`_pair_refit_stands`).
    ``alpha`` and ``z_min_time`` were set on the blind study's
    seed-0 cases (``benchmarks/blind_diagnosis.py``) and checked on seed 1;
    ``min_error_ratio`` (1.2 there) was lowered to 1.1 on seeds 7 and 8, once every
    nonlinear refit nests the null refit (before, a candidate could fit worse than the
    null and the ratio carried that search noise), and to 1.05 on the stored rankings of
    development seeds 2, 7, 11, 23, 31 and 41 (two runs) replayed under the gate alone:
    with the held-out confirmation kept, one more true nonlinearity passed on five of the
    seven runs (mild rate limits and backlash cut the error by x1.05-1.09 and are
    confirmed on VAL), two wrong verdicts on other effects became other wrong ones, no
    verdict on none changed, and the wrong nonlinearities that cut the error by more
    (x1.1-1.4, in lag cases) stay refused by VAL.  ``alpha_amplitude`` (the
    conventional 5 %, the amplitude test and the held-out confirmation being separate
    evidence) was checked on seeds 7 and 8.
    ``alpha_held_out_first``: a ``cross_coupling`` passes as well where the held-out records
    carry the evidence and the identification records only support it: held-out z-score
    at least the one-sided normal quantile of ``alpha`` (3.09), its gain's test below this
    level, a positive gap and a held-out BIC drop of at least
    :data:`jaxgwo._diagnose_which.HELD_OUT_FIRST_BIC` (``score_candidate``'s
    ``held_out_alpha``).  The pilot's
    off-axis corrections during the sweeps are small, so a real coupling's gain can be
    uncertain there while the held-out multisteps show it plainly (seed-113 case_057: gain
    0.095 for 0.144, p 0.02, held-out z 3.67).  Set on the stored rankings of seeds 113 (with
    and without the attitude) and 131, where it admits that case alone: no other
    cross-coupling failing noise had a held-out z above 2.92 with its p below 0.05, and
    the three above 3.09 (a none case among them) had p 0.68-0.95.  ``0`` switches it off.
    ``alpha_coupling_gain``: a ``cross_coupling`` fitted on the paper model alone (no
    structure finding) whose gain's test passes at this level needs the held-out records
    only not to contradict it (``z_min`` and a positive gap), as a large error cut does.
    The held-out multisteps carry little off-axis stick of the pilot's own (0.005 rms);
    most of it is the hold loop's answer to the gusts, which the coupling feeds back into
    the measured axis, so a weak coupling's term correlates with the gust error there.
    The true model itself (true paper parameters and gain) predicts the held-out records
    of five of the seven paper couplings that the identification records found at p below
    1e-3 but the held-out ones refused worse than the same model without its coupling
    (seed-157 case_006, gain 0.213: error 3.700e-5 against 3.676e-5; seed-149 case_039,
    151/038, 191/004, 191/009), while its identification error drops on all seven
    (scratch ``/work/runs/s41/orc.py``).  Set on the stored rankings of the eleven fresh
    draws 131-191 (792 cases): without a structure finding no cross-coupling fitted to a
    case without one had a gain p below 7.3e-4, and six true ones failing the held-out
    confirmation had 3.6e-10..1.6e-6; 1e-5 lies between.  It admits four of those six
    (149/039, 179/008, 179/010, 191/009; the other two the held-out records contradict).
    On an R-50, whose own coupling through its flapping fits gains of 0.06-0.22 at p
    down to 2e-16 on cases without one, a structure finding is made on 198 of 201 cases
    and the rule does not act there.  ``0`` switches it off.
    ``alpha_resonance``: a resonance that the output-error refit finds on the paper model
    alone, whose matched filter (:func:`_resonance_in_box`) passes at this level, needs the
    held-out records only not to contradict it (``z_min`` and a positive gap) instead of
    confirming it (``z_min_time``), as a coupling far beyond noise does
    (``alpha_coupling_gain``).  The held-out 3-2-1-1s and doublets put
    little power above 8 Hz, where the vocabulary's resonances lie, so the true model itself
    confirms them weakly there (seed-181 case_063: held-out z 0.6), and the matched filter's
    :math:`z^2` is calibrated against :math:`\chi^2_3` on cases without a mode (25 ``none``
    cases of seeds 131-157: mean 3.0, largest z 2.98, p 0.03; this level is z 5.09).
    Fresh seed 227's case_029 (paper plant, a 10.42 Hz mode at pole damping 0.071, zeros
    0.248, the sweeps to 13.1 Hz): the refit 10.51 Hz, 0.062, 0.222 at matched-filter z
    5.34 (p 3e-6), while ``J`` fitted no resonance (zeros 1.31, p 0.03), and held-out z 0.77
    with gap 0.31 refused it, so the verdict was ``none``.  On the stored rankings of seeds
    199, 211, 223 and 227 (288 cases) it changes no other verdict: the other refits past
    this level that failed the confirmation were a true mode whose held-out gap is negative
    (227/014, z 5.25) and a rate limit's pair (199/033, z 9.48, gap -0.22, its ``J`` worse
    than the base's).  Set first at 1e-5 (z 5.09), lowered to ``alpha`` (1e-3, z 4.03) in
    session 59: on the stored rankings of blind seeds 367-389 three true paper resonances
    answered ``none`` with their refit on the mode at z 4.20-4.94 and a positive held-out
    gap (367/019, 9.74 Hz for 9.71, z 4.20, gap 0.019; 379/058, 10.1 for 9.90, 4.58, 0.21;
    379/068, 11.0 for 11.0, 4.94, 0.11), while no case of another class fitted a resonance
    of the box past z 3.41 (a rate limit's, 383/005).  Checked on the paper ``none`` and
    resonance cases of seeds 311-359, regenerated and rediagnosed before the change (107
    cases): one more true resonance passes (347/046, 10.3 Hz for 10.2, z 4.11, gap 0.25),
    and the ``none`` cases' refits that lay in the box reached z 1.35.  ``0`` switches it
    off.
    ``alpha_resonance_j_alone``: the level a resonance's ``J`` F-test must pass on the
    paper model alone where its output-error refit finds nothing at ``alpha``
    (:func:`_resonance_on_j_alone`).  ``0`` refuses every such resonance; ``alpha`` (or
    more) switches the rule off.
    ``j_null_ratio``: a nonlinear candidate's ``J`` against the null refit's (F-test at
    ``alpha``, 328be67) counts as its identification evidence and effect size only where
    its ``J`` is at most this fraction of the null refit's.  The true paper rate limits
    that test was set on fitted 0.04-0.27 of it (session 40's rediagnoses; seed-181
    case_011 1.19 against 33.3; seed-191 case_070, 0.32).  On fresh seed 199 two paper
    resonances near the sweeps' top (case_005 and case_040, 15.97 and 15.66 Hz) passed it
    as rate limits at 0.64 and 0.69 (and a saturation at 0.49), with output-error p
    0.13-0.15, and a paper rate limit as a saturation at 0.61 (case_063, p 0.29), while
    the true nonlinear verdicts that passed it fitted 0.02-0.37, but for two backlashes at
    0.47 and 0.64 that pass on their output error (p 3e-8, 2e-56).  Set on seed 199 (0.4),
    before seed 211 was looked at; replayed there it changes no verdict, though six true
    nonlinear verdicts fit 0.42-0.67: each passes on its output error (p 1e-7 or less).
    The ratio decides only where the output error is weak.  ``inf``: the F-test alone, as
    before.
    ``nsigma``: the random-error multiple that flags a frequency band.
    ``structure_zeta_z``: when the top candidate is a ``structural_mode`` whose fitted zero
    damping exceeds it (its zeros are real for values above 1), the fit describes no lightly
    damped resonance (a pole-zero dipole, zero damping 0.1-0.3 in the vocabulary) but a
    pole pair the paper model lacks, such as a coupled rotor or stabilizer-bar mode of the
    airframe.  That mode is then reported as a *structure* finding, kept in the model, and
    the other candidates are refitted and ranked on top of it (the verdict is theirs).
    When the top candidate is a ``time_delay`` instead, a ``structural_mode`` is fitted on
    top of the delay; one that beats noise against the delay alone, with zero damping
    above this threshold, is a structure finding as well (marked
    ``found_behind_time_delay``: a long delay takes the top place from it); so is one that
    beats noise below a nonlinearity at the top and fits ``J`` better than it (marked
    ``found_behind_nonlinearity``, :func:`_pair_behind_nonlinearity`).  An
    output-error refit of a ``structural_mode`` with zero damping above it never stands in
    for the mode's ``J`` fit (:func:`_takes_time_domain_path`).
    ``inf`` switches all three off.  Set from the blind study's seed-23 cases: on every R-50
    plant where a structural_mode beat noise (18 of 21) it fitted zero damping 1.5 (the
    search box's top); the two true structural modes it found fitted 0.19 and 0.33.
    ``lag_over_delay``: when the best candidate is a ``time_delay`` and a lag
    (``sensor_lag``, ``rotor_flapping``) that also beats noise scores within this margin
    of it, the lag is ranked first.  The two do not mimic each other alike: with the
    servo refitted, a delay imitates a lag's phase and the servo its magnitude, while a
    long delay's phase keeps growing past where a lag's stops at 90 deg.  On the stored
    rankings of development seeds 2, 7, 11, 23, 31 and 41, every true delay beat the best
    passing lag by 0.25 or more (24 cases; 18 more had no lag passing), and every one of
    the 24 true lags called a delay had a passing lag within 0.15 of it, the true one in
    12 (the other 12 the other lag, which no cyclic excitation separates from it,
    :data:`SEPARATING_EXCITATION`, so both lags move: :func:`_lag_over_delay`).  Replayed
    on those rankings it takes top-1 from 172 to 184 of 352 effect cases and top-2 from
    206 to 218, and moves no true delay; ``0`` switches this off.  It orders the ranking
    against the paper model only, not one on top of a structure finding: every case it
    moved there was a paper plant, and on an R-50 with its extra mode a true 19 ms delay
    led its lags by only 0.11 (seed-31 case_043, estimated at 19.6 ms).
    ``alpha_lag_on_structure``: on top of a structure finding, the level of the ``J``
    F-test of a ``rotor_flapping`` or ``time_delay`` fit (where above ``alpha``), and a
    delay fitted below the vocabulary's range then ranks after a passing lag
    (:func:`_lag_over_short_delay`).  The pair model leaves the airframe's model-form
    error in ``J``, which the F-test counts as noise, so the test is conservative there:
    on the 33 R-50 ``none`` cases of the stored draws 367-441 every such fit had p 0.03
    or more (31 of them returned to no lag or delay at all, ``J`` unchanged), while the
    30 R-50 flapping lags (10-27 ms) fitted 0.7-11 ms at p 1e-4 to 0.8, one of them
    named.  Beside the flybar's pair a lag inside the rotor/fuselage loop fits as well as
    a delay of 4-10 ms, below the vocabulary's 10 ms, where the R-50's true delays fitted
    9.1 ms (for 11.0) and 16-83 ms.  Replayed on those draws' stored rankings (1024 effect
    cases; ``/work/runs/s62/replay.py``) the two together name ten more R-50 flapping lags
    and an R-50 delay, make a flapping lag answered ``none`` a delay, and change no other
    verdict.  Rediagnosed (37 R-50 cases of them, ``/work/runs/s62/N1.json``): 14 of the
    20 flapping lags among them are named (one before); the delays, gyro filters,
    saturations and ``none`` cases keep their verdicts.  Set there, in sample.
    ``0`` switches it off (``alpha`` alone, every delay where it ranks).
    ``alpha_pressed_pair``: a structure finding's pair above the vocabulary's 3 Hz floor
    with pole damping 0.15 or more (an airframe pair pressed up, :func:`_pair_pressed_up`)
    is replaced by a pair refitted under the floor with a resonance beside it
    (:func:`fit_flybar_and_resonance`) where those two fit ``J`` better than the one pair
    by the F-test at this level (three parameters added).  A lightly damped pair is
    replaced wherever the two fit better, as before.  Without the test, a paper plant's
    own 9 Hz airframe pair (pole damping 0.15, zeros 1.5; the suite's structure case) was
    replaced by a 1.9 Hz pair and a resonance.  On the 76 cases of the stored draws
    367-449 with a structure finding above 3 Hz (``/work/runs/s63/B1.json`` against the
    parent) the replacement takes five verdicts from wrong to right at 0.05 (three R-50
    resonances, two flapping lags) and two from right to wrong (a flapping lag answered
    ``structural_mode``, an 11.0 ms delay answered ``rotor_flapping``); four and one at
    0.01, two and one at 1e-3, seven and two without the test.  Set at the conventional
    0.05, in sample.
    ``0`` switches it off.
    ``nonlinearity_by_j``: when the best candidate is a servo nonlinearity and another
    that also beats noise scores within this margin of it with a lower ``J``, the one of
    lowest ``J`` among them is ranked first (:func:`_nonlinearity_by_j`): their scores, read
    from output error that the gusts dominate, do not separate them, while ``J`` reads the
    coherent response each fits.  On the stored rankings of blind seeds 311-401 (twelve
    cases with two nonlinearities beating noise, ``/work/runs/s59/nl2scan.py``) the true
    one fitted the lower ``J`` in eleven; the two wrong verdicts among them were R-50 rate
    limits called ``saturation`` on the pair-free path by 0.002 and 0.016 (359/017: ``J``
    20.4 against the rate limit's 11.9; 401/058: 28.4 against 11.7), and every right one
    led by 0.31 or more (the exception to lower ``J``, R-50 saturation 373/023 at 65.5
    against 50.0, by 1.9).  Set there, in sample; ``0`` switches it off.
    ``flapping_between_airframes``: where nothing beats noise on top of a structure
    finding, name a ``rotor_flapping`` that the pair fit and the lead-lag airframe both read
    as a lag (:func:`_flapping_between_airframes`; set in session 83 on development seed
    9101, in sample).  ``False`` switches it off.
    """

    identify: IdentifySettings = field(default_factory=lambda: IdentifySettings(
        method="wls-igwo+polish", wolves=12, iterations=30, n_frequencies=80, polish_steps=40, w_max=120.0))
    wolves: int = 12
    iterations: int = 30
    alpha: float = 1e-3
    z_min: float = -2.0
    z_min_time: float = 1.0
    min_error_ratio: float = 1.05
    held_out_bic: float = 2.0
    strong_error_ratio: float = 1.5
    pair_free_error_ratio: float = 1.08
    alpha_amplitude: float = 0.05
    alpha_held_out_first: float = 0.05
    alpha_coupling_gain: float = 1e-5
    alpha_resonance: float = 1e-3
    alpha_resonance_j_alone: float = 1e-4
    j_null_ratio: float = 0.4
    min_gap: float = -0.5
    nsigma: float = 3.0
    structure_zeta_z: float = 1.0
    lag_over_delay: float = 0.15
    alpha_lag_on_structure: float = 1e-2
    alpha_pressed_pair: float = 0.05
    nonlinearity_by_j: float = 0.15
    flapping_between_airframes: bool = True
    candidates: tuple[str, ...] = tuple(EFFECTS)
    nonlinear_wolves: int = 12
    nonlinear_iterations: int = 15
    nonlinear_profile_points: int = 12
    nonlinear_refine_rows: int = 6
    nonlinear_polish_steps: int = 60
    seed: int = 0

    def __post_init__(self):
        for name in ("wolves", "nonlinear_wolves"):
            _need_int(name, getattr(self, name), 4, "a grey wolf pack needs alpha, beta, delta "
                      "and an omega")
        for name in ("iterations", "nonlinear_iterations"):
            _need_int(name, getattr(self, name), 1, "IGWO iterations of the refits")
        _need_int("nonlinear_profile_points", self.nonlinear_profile_points, 2,
                  "a profile needs both ends of the effect's box")
        _need_int("nonlinear_refine_rows", self.nonlinear_refine_rows, 1,
                  "each nonlinear candidate is refined from its best profile rows")
        _need_int("nonlinear_polish_steps", self.nonlinear_polish_steps, 1, "L-BFGS-B steps of the nonlinear finish")
        for name in ("alpha_held_out_first", "alpha_coupling_gain", "alpha_resonance", "alpha_resonance_j_alone",
                     "alpha_lag_on_structure", "alpha_pressed_pair"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and 0.0 <= v < 1.0):
                raise ValueError(f"{name} must be a level in [0, 1) (0: off), got {v!r}.")
        if not (isinstance(self.held_out_bic, (int, float)) and self.held_out_bic >= 0.0):
            raise ValueError(f"held_out_bic must be a BIC difference >= 0 (0: any held-out gain), got "
                             f"{self.held_out_bic!r}.")
        for name in ("min_error_ratio", "strong_error_ratio", "pair_free_error_ratio"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and v >= 1.0):
                raise ValueError(
                    f"{name} must be a number >= 1 (an error ratio: null error / candidate error), got {v!r}."
                )
        if not (isinstance(self.j_null_ratio, (int, float)) and self.j_null_ratio > 0):
            raise ValueError(f"j_null_ratio must be a positive J ratio (candidate / null refit; inf: off), "
                             f"got {self.j_null_ratio!r}.")
        for name in ("lag_over_delay", "nonlinearity_by_j"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and v >= 0):
                raise ValueError(f"{name} must be a score margin >= 0 (0: off), got {v!r}.")
        if not (isinstance(self.structure_zeta_z, (int, float)) and self.structure_zeta_z > 0):
            raise ValueError(f"structure_zeta_z must be a positive number (inf: off), got {self.structure_zeta_z!r}.")
        unknown = [c for c in self.candidates if c not in EFFECTS]
        if unknown:
            raise ValueError(f"unknown candidate effect(s) {unknown}; choose from {', '.join(EFFECTS)}.")

    @classmethod
    def quick(cls, **changes) -> DiagnoseSettings:
        """The small searches the test suite and the blind study's ``--quick`` run: the
        nominal fit 10 wolves x 20 iterations (30 polish steps), the linear candidates 10 x
        25, the nonlinear ones 6 x 6 with 6 profile points, 3 refined rows and 10 L-BFGS-B
        steps.  It is the defaults with those sizes replaced, so every threshold is the
        default's and a quick verdict is the default's rules on a shorter search (the blind
        study's numbers are the defaults').  ``changes`` replace fields as
        :func:`dataclasses.replace` does."""
        default = cls()
        small = dataclasses.replace(
            default, identify=dataclasses.replace(default.identify, wolves=10, iterations=20, polish_steps=30),
            wolves=10, iterations=25, nonlinear_wolves=6, nonlinear_iterations=6, nonlinear_profile_points=6,
            nonlinear_refine_rows=3, nonlinear_polish_steps=10,
        )  # fmt: skip
        return dataclasses.replace(small, **changes)


def _nonlinear_budget(settings: DiagnoseSettings) -> dict:
    """:func:`jaxgwo._diagnose_which.fit_nonlinear_candidates`'s search sizes from ``settings``."""
    return dict(wolves=settings.nonlinear_wolves, iterations=settings.nonlinear_iterations,
                profile_points=settings.nonlinear_profile_points, refine_rows=settings.nonlinear_refine_rows,
                polish_steps=settings.nonlinear_polish_steps)  # fmt: skip


@dataclass(frozen=True)
class TimeDomainRefit:
    """The base model (the paper model, with a structure finding's pole pair held) refitted
    by output error to the identification time histories with no effect added: the null
    refit every time-domain candidate is tested against (:func:`fit_nonlinear_candidates`,
    ``include_null``).  It is fitted on TRAIN only, so its held-out R^2 is a held-out score
    like the candidates'.  The frequency-domain fit weights the response's coherent points,
    this one the time histories; where the two differ on VAL, the difference is the fit's,
    not an unmodelled effect's."""

    params: dict
    """``K, tau, M, omega_s, zeta_s`` (true sign, the output gain in ``K``)."""
    effects: dict
    """The base's effects, held (a structure finding's mode), else empty."""
    train_mse: float
    """Identification output error, taken about each record's mean (:func:`_closed_form_gain`)."""
    val_r2: float
    val_tic: float
    gap_closed: float
    """Of the held-out R^2 gap the base leaves, as a candidate's ``gap_closed``."""
    predicted: tuple = field(repr=False, default=())


@dataclass(frozen=True)
class Diagnosis:
    """Everything a diagnosis found (see :meth:`to_json` for the stable report)."""

    channel: str
    nominal_params: dict
    nominal_cost_J: float
    nominal_r2: float
    nominal_tic: float
    mismatch: FrequencyMismatch = field(repr=False)
    residuals: ResidualTests = field(repr=False)
    off_axis_residuals: ResidualTests | None = field(repr=False)
    amplitude: AmplitudeDependence = field(repr=False)
    noise_limited_bands_hz: list = field(repr=False)
    ranking: tuple[CandidateScore, ...] = field(repr=False)
    verdict: str
    combined: CandidateScore | None = field(repr=False)
    skipped: dict = field(repr=False)
    val_time: tuple = field(repr=False)
    val_measured: tuple = field(repr=False)
    val_nominal: tuple = field(repr=False)
    response_w: np.ndarray = field(repr=False)
    suggestion: str = ""
    structure: CandidateScore | None = field(repr=False, default=None)
    """The extra pole pair (a ``structural_mode`` with real zeros) that the ranking is
    built on, or ``None`` (:class:`DiagnoseSettings`, ``structure_zeta_z``)."""
    paper_ranking: tuple[CandidateScore, ...] = field(repr=False, default=())
    """With a structure finding: the ranking against the paper model alone that found it."""
    gyro: GyroPath = field(repr=False, default_factory=lambda: GyroPath(False, note="not tested"))
    """The gyro's path read against a logged attitude (:func:`jaxgwo._diagnose_where.gyro_path`)."""
    nominal_simulates: bool = True
    """Whether the nominal's held-out simulation is finite.  A long delay can drive the
    delay-free paper fit to a servo no simulation survives; its prediction is then taken
    as zero (``val_nominal``), so its ``nominal_r2`` of about 0 means it predicts nothing."""
    refit: TimeDomainRefit | None = field(repr=False, default=None)
    """The base refitted by output error with no effect (the time-domain candidates' null),
    or ``None`` where no candidate was refitted."""
    unconfirmed: tuple[str, ...] = ()
    """With a ``none`` verdict, the candidates (in ranking order) the identification records
    support at ``alpha`` but the held-out records refuse (:func:`_unconfirmed`): no verdict,
    but where the two sets of records disagree."""

    def to_json(self) -> dict:
        """The stable JSON report of issue 5 (extra keys: ``skipped``, ``suggestion``,
        ``structure``, ``ranking_paper_model``, ``time_domain_refit``, ``unconfirmed``, details).

        ``time_domain_refit`` is :class:`TimeDomainRefit` (``params``, ``effects``,
        ``train_mse``, ``val_r2``, ``val_tic``, ``gap_closed``), or ``null``.

        With a structure finding, ``structure`` holds the extra mode (its ``val_r2`` and
        ``gap_closed`` against the nominal), ``ranking`` and ``verdict`` are the effects
        ranked on top of it (their ``gap_closed`` of the gap the mode leaves), and
        ``combined_top2`` is the mode with the top effect; ``ranking_paper_model`` keeps the
        ranking against the paper model alone.  Without one, ``structure`` is ``null``."""

        def num(x):
            x = float(x)
            return x if math.isfinite(x) else None

        def cand(c: CandidateScore) -> dict:
            flat = {p: num(v) for e in c.effects for p, v in c.params[e].items()}
            sig = {p: num(v) for e in c.effects for p, v in c.sigma.get(e, {}).items()}
            return {
                "effect": "+".join(c.effects), "params": flat, "params_sigma": sig,
                "val_r2": num(c.val_r2), "val_tic": num(c.val_tic), "cost_J": num(c.cost_J),
                "gap_closed": num(c.gap_closed), "score": num(c.score), "delta_bic": num(c.delta_bic),
                "nominal_J": num(c.nominal_J), "delta_bic_val": num(c.delta_bic_val), "train_p": num(c.train_p),
                "z_score": num(c.z_score), "detail": {k: num(v) for k, v in c.detail.items()}, "beats_noise": c.beats_noise, "signature_agreement": num(c.agreement),
            }  # fmt: skip

        refit = None
        if self.refit is not None:
            r = self.refit
            refit = {"params": {k: num(v) for k, v in r.params.items()},
                     "effects": {e: {p: num(v) for p, v in ps.items()} for e, ps in r.effects.items()},
                     "train_mse": num(r.train_mse), "val_r2": num(r.val_r2), "val_tic": num(r.val_tic),
                     "gap_closed": num(r.gap_closed)}  # fmt: skip
        comb = None
        if self.combined is not None:
            comb = {"effects": list(self.combined.effects), "val_r2": num(self.combined.val_r2),
                    "gap_closed": num(self.combined.gap_closed), "val_tic": num(self.combined.val_tic),
                    "cost_J": num(self.combined.cost_J),
                    "params": {p: num(v) for e in self.combined.effects for p, v in self.combined.params[e].items()}}  # fmt: skip
        return {
            "channel": self.channel,
            "nominal": {"params": {k: num(v) for k, v in self.nominal_params.items()}, "cost_J": num(self.nominal_cost_J),
                        "val_r2": num(self.nominal_r2), "val_tic": num(self.nominal_tic),
                        "simulates": bool(self.nominal_simulates)},  # fmt: skip
            "where": {
                "bands_hz": self.mismatch.bands_hz,
                "worst_hz": num(self.mismatch.worst_hz),
                "residual_white": bool(self.residuals.white),
                "input_residual_peak_lag_s": num(self.residuals.input_residual_peak_lag_s),
                "amplitude_dependent": bool(self.amplitude.dependent),
                "noise_limited_bands_hz": self.noise_limited_bands_hz,
                "equivalent_delay_s": num(self.mismatch.equivalent_delay_s),
                "resonance_hz": None if self.mismatch.resonance_hz is None else num(self.mismatch.resonance_hz),
                "amplitude_note": self.amplitude.note,
                "gyro_path": {
                    "tested": bool(self.gyro.tested), "filter_found": self.gyro.shows_filter(),
                    "cutoff_hz": num(self.gyro.cutoff_hz), "cutoff_range_hz": [num(v) for v in self.gyro.cutoff_range_hz],
                    "p_value": num(self.gyro.p_value), "note": self.gyro.note,
                },  # fmt: skip
            },
            "ranking": [cand(c) for c in self.ranking],
            "verdict": self.verdict,
            "combined_top2": comb,
            "skipped": dict(self.skipped),
            "suggestion": self.suggestion,
            "structure": None if self.structure is None else cand(self.structure),
            **({"ranking_paper_model": [cand(c) for c in self.paper_ranking]} if self.structure is not None else {}),
            "time_domain_refit": refit,
            "unconfirmed": list(self.unconfirmed),
        }

    def summary(self) -> str:
        """A short plain-language summary for the terminal."""
        lines = []
        bands = self.mismatch.bands_hz
        if bands:
            lo, hi = min(b[0] for b in bands), max(b[1] for b in bands)
            d = self.mismatch.equivalent_delay_s
            trend = "phase lag growing with frequency" if d > 2 * self.mismatch.equivalent_delay_sigma_s else "no systematic phase trend"
            lines.append(f"Gap lies mainly between {lo:.2g} and {hi:.2g} Hz ({trend}); worst at {self.mismatch.worst_hz:.2g} Hz.")
        else:
            lines.append("The nominal model stays within the response's random-error bounds at every frequency.")
        top_hz = float(np.max(self.response_w)) / (2.0 * np.pi) if np.size(self.response_w) else math.nan
        blind = [b for b in self.noise_limited_bands_hz if b[1] >= 0.99 * top_hz]
        if blind:
            # the R-50 resonances of the blind study lie there (coherence 0.05-0.44 at the mode)
            lines.append(
                f"Above {blind[0][0]:.3g} Hz (to the analysed {top_hz:.3g} Hz) the coherence is too low for the "
                "response to be measured: a resonance there cannot show in the frequency-domain fits. A sweep with "
                "more energy at those frequencies would measure it."
            )
        if self.amplitude.dependent:
            lines.append(f"The response depends on amplitude ({self.amplitude.note}).")
        if self.gyro.tested:
            lines.append(f"{self.gyro.note[:1].upper()}{self.gyro.note[1:]}.")
        if not self.nominal_simulates:
            p = self.nominal_params
            lines.append(
                f"The paper model identified on TRAIN does not simulate (servo {p['omega_s']:.3g} rad/s, damping "
                f"{p['zeta_s']:.2g}): its held-out prediction is taken as zero, so its R^2 of {self.nominal_r2:.3f} "
                "means it predicts nothing."
            )
        before = self.nominal_r2
        if self.structure is not None:
            sm = self.structure.params["structural_mode"]
            before = self.structure.val_r2
            why = ("it lies below the vocabulary's resonances (3 Hz and up)" if math.log(sm["freq_hz"]) < _Z_LO[3]
                   else "its zeros are real")  # _airframe_pair
            lines.append(
                f"The paper model lacks a pole pair near {sm['freq_hz']:.3g} Hz (damping {sm['zeta_p']:.2g}; {why}, "
                "so it is no lightly damped structural resonance but a mode of the airframe such as a "
                "coupled rotor or stabilizer-bar mode). Adding it: held-out R^2 "
                f"{self.nominal_r2:.3f} -> {before:.3f}. The effects are ranked on top of it."
                + (" It shows only on top of a time delay, which hides it from the paper model alone."
                   if self.structure.detail.get("found_behind_time_delay") else "")
                + (" A nonlinearity, bent round this missing pair, had taken the top place from it on the paper "
                   "model alone; it is ranked again on top of the pair."
                   if self.structure.detail.get("found_behind_nonlinearity") else "")
            )
        what = "paper model with that mode" if self.structure is not None else "paper model"
        r = self.refit
        refit_better = r is not None and r.val_r2 >= before + REFIT_MARGIN_R2
        if self.verdict == "none" and refit_better:
            lines.append(
                f"No candidate effect beats noise. Refitted to the identification time histories by output error, "
                f"with no effect added, the {what} predicts the held-out records with R^2 {r.val_r2:.3f} where its "
                f"frequency-domain fit gives {before:.3f} ({100 * r.gap_closed:.0f} % of the gap): the {what} itself, "
                "fitted to the time histories, accounts for that difference, and no effect added to it explains "
                "more beyond noise. That refit is the better model (time_domain_refit in the JSON report); the rest "
                "is disturbance or noise."
            )
        elif self.verdict == "none":
            lines.append(
                f"No candidate effect beats noise: the held-out R^2 {before:.3f} is what the {what} can do on this "
                "data (the rest is disturbance or noise)."
            )
        else:
            top = self.ranking[0]
            lines.append(f"Most likely cause: {_params_text(top)}.")
            if top.detail.get("delay_inverse_variance_mean"):
                d = top.detail
                scaled = (f", its bound scaled by {d['delay_scale_factor']:.2g} for their disagreement"
                          if d["delay_scale_factor"] > 1.0 else "")
                which = "output-error refit" if d.get("estimate_output_error") else "frequency-domain fit"
                lines.append(
                    f"The delay is the inverse-variance mean of the frequency-domain fit's reading "
                    f"({1e3 * d['j_delay_s']:.1f} ms +-{1e3 * d['j_sigma_delay_s']:.1f}) and the output-error refit's "
                    f"({1e3 * d['td_delay_s']:.1f} ms +-{1e3 * d['td_sigma_delay_s']:.1f}){scaled}: the two trade it "
                    f"against the servo differently. The held-out scores below are the {which}'s."
                )
            elif top.detail.get("estimate_output_error") and top.detail.get("cutoff_from_gyro_path"):
                lines.append("The model with it has its servo and rotor term refitted to the identification time "
                             "histories (output error) with the cutoff held at the gyro path's measurement; the "
                             "held-out scores below are that model's.")  # fmt: skip
            elif top.detail.get("estimate_output_error"):
                j = ", ".join(f"{p} {top.detail[f'j_{p}']:.3g}" for e in top.effects for p in top.params[e]
                              if f"j_{p}" in top.detail)  # fmt: skip
                why = next((w for e, w in _WHY_OUTPUT_ERROR.items() if e in top.effects), "")
                lines.append("Estimated by refitting the model with it to the identification time histories (output "
                             f"error), where the frequency-domain fit that found it read {j}: {why}.")  # fmt: skip
            if "two_readings_half_spread" in top.detail:
                lines.append("The +- counts random error and half the difference between the frequency-domain fit's "
                             "reading and the output-error refit's, which trade it against the servo differently.")
            moved = _refitted_pair(top, self.structure)
            if moved is not None:
                lines.append(f"Beside it the airframe's pole pair refits to {moved[0]:.3g} Hz (damping {moved[1]:.2g}); "
                             "the model with the effect holds that pair (pair_freq_hz in the JSON detail).")
            if top.detail.get("passed_on_gain_alone"):
                lines.append(
                    f"The identification records carry its evidence (gain p {top.train_p:.2g}); the held-out "
                    f"records do not confirm it (z {top.z_score:.1f}), their off-axis stick being mostly the hold "
                    "loop's answer to the gusts. Multisteps on the off-axis cyclic would confirm it."
                )
            if top.detail.get("td_passed_on_matched_filter_alone") and top.detail.get("time_domain_path"):
                mode = top.params["structural_mode"]
                lines.append(
                    f"The identification records carry its evidence (matched-filter z {top.detail['td_mf_z']:.1f}); "
                    f"the held-out records do not confirm it (z {top.z_score:.1f}), as records that excite "
                    f"{mode['freq_hz']:.3g} Hz little cannot. Held-out records with a sweep through it would confirm it."
                )
            if top.detail.get("passed_on_amplitude_backing"):
                lines.append(
                    "The identification records carry its evidence (output-error p "
                    f"{top.detail['p_output_error']:.2g}, and the response changes with amplitude as it predicts); "
                    "the held-out records do not confirm "
                    f"it (z {top.z_score:.1f}). Held-out records at two stick amplitudes would confirm it."
                )
            if top.detail.get("passed_at_structure_level"):
                lines.append(
                    f"Its J evidence (p {top.train_p:.2g}) passes at the level read beside the airframe's pole pair "
                    "(alpha_lag_on_structure), not at alpha: the pair model's own misfit makes J's F-test "
                    "conservative there, but this is weaker evidence than a finding at alpha."
                )
            if top.detail.get("named_between_airframes"):
                lines.append(
                    f"The held-out records do not show it beyond noise (z {top.z_score:.1f}): it is named because both "
                    f"descriptions of the airframe read a lag on the identification records, the extra pole pair "
                    f"{1e3 * top.detail['tau_f_pair_s']:.3g} ms and a lead-lag times a low pole pair "
                    f"{1e3 * top.detail['tau_f_airframe_s']:.3g} ms, the latter within the vocabulary's flapping "
                    "lags; on the blind study's R-50 plants without an effect the pair read none. Held-out sweeps, "
                    "rather than multisteps, would confirm it."
                )
            if "ranked_over_short_delay_s" in top.detail:
                lines.append(
                    f"A time delay of {1e3 * top.detail['ranked_over_short_delay_s']:.3g} ms fits as well or better, "
                    f"shorter than any of the vocabulary's delays ({_DELAY_RANGE_MS}): beside the airframe's pole "
                    "pair a lag imitates one."
                )
            if "J_over_pair_J" in top.detail:
                lines.append(
                    f"On the paper model a broad pole pair near {top.detail['over_pair_freq_hz']:.3g} Hz (real zeros) "
                    f"also beats noise, but it fits the measured response worse than this nonlinearity (whose J is "
                    f"{top.detail['J_over_pair_J']:.2f} times the pair's): the pair imitated the nonlinearity's bend "
                    "of the response, and is taken for no mode of the airframe."
                )
            if self.verdict == "cross_coupling":
                lines.append(_AIRFRAME_COUPLING_NOTE)
            if top.detail.get("passed_on_held_out_records"):
                lines.append(
                    f"The held-out records carry its evidence (z {top.z_score:.1f}); the identification records "
                    f"support it only weakly (p {top.train_p:.2g}). Sweeps with more off-axis stick activity "
                    "would measure it on its own."
                )
            bracketed = any(f"{stem}_airframe_s" in top.detail for *_p, stem in AIRFRAME_LAGS.values())
            if self.structure is not None and bracketed:
                lines.append(
                    "The +- counts random error and, for the model-form bias of that extra pole pair (an "
                    "approximation of the airframe), the spread between it and a lead-lag times a low pole pair: "
                    "on the blind study's R-50 plants the pair read nearly every delay and flapping lag short and the "
                    "lead-lag long."
                )
            elif self.structure is not None:
                # blind-study R-50 delays: 0-13.5 ms low against bounds of 1.2-2.6 ms
                lines.append(
                    "The +- counts random error, widened where the misfit runs smoothly across frequency; "
                    "fitted on top of that extra pole pair, an approximation of the airframe, the parameters "
                    "still carry a model-form bias it can understate (README, 'What limits it')."
                )
            gap = "gap" + (" left by the paper model with that mode" if self.structure is not None else "")
            if top.gap_closed >= 0.0:
                lines.append(f"Adding it closes {100 * top.gap_closed:.0f} % of the held-out R^2 {gap} "
                             f"({before:.3f} -> {top.val_r2:.3f}).")  # fmt: skip
            else:
                # a filter measured on the gyro path, or a linear candidate the held-out records
                # only had not to contradict (DiagnoseSettings: z_min, min_gap)
                if top.detail.get("cutoff_from_gyro_path"):
                    why = ("its evidence is the gyro path against the attitude, which does not depend on the model; "
                           "the model does not carry it to these records")
                elif top.detail.get("confirmed_against_null_refit_only"):
                    why = (f"the held-out records confirm it against the {what} refitted to the identification time "
                           "histories without it (below), which predicts them worse still, so the frequency-domain "
                           "fit's lead is that time-domain fit's model-form error, not the effect's")
                else:
                    why = "the held-out records do not confirm it"
                lines.append(f"Adding it lowers the held-out R^2 ({before:.3f} -> {top.val_r2:.3f}, "
                             f"{100 * top.gap_closed:.0f} % of the {gap}): {why}.")  # fmt: skip
            if self.combined is not None:
                # with a structure finding the first of the two is its extra pole pair
                names = (("the extra pole pair", *self.combined.effects[1:]) if self.structure is not None
                         else self.combined.effects)  # fmt: skip
                lines.append(
                    f"With {' + '.join(names)}: R^2 {self.combined.val_r2:.3f} "
                    f"({100 * self.combined.gap_closed:.0f} % of the gap)."
                )
            against_refit = bool(top.detail.get("confirmed_against_null_refit_only"))
            if r is not None and (abs(r.val_r2 - before) >= REFIT_MARGIN_R2 or against_refit):
                tail = ("." if r.val_r2 < top.val_r2 - REFIT_MARGIN_R2 or against_refit else
                        ": the held-out records do not tell that refit from the model with the effect, so the "
                        "evidence for the effect is the identification records'."
                        if r.val_r2 <= top.val_r2 + REFIT_MARGIN_R2 else
                        ": it predicts the held-out records better than the model with the effect, so the evidence "
                        "for the effect is the identification records' alone.")  # fmt: skip
                lines.append(
                    f"For comparison, the {what} refitted to the identification time histories by output error, "
                    f"with no effect added (the null the time-domain candidates are tested against), gives R^2 "
                    f"{r.val_r2:.3f}{tail}"
                )
        by_name = {c.effects[0]: c for c in self.ranking}
        for name in self.unconfirmed[:2]:
            c = by_name[name]
            # R^2 and z against the model the candidate was tested against
            ref, of = ((r.val_r2, f" against the {what} refitted by output error") if r is not None
                       and _against_null_refit(c) else (before, ""))  # fmt: skip
            numbers = f"R^2 {ref:.3f} -> {c.val_r2:.3f}{of}, z {c.z_score:.1f}"
            held = (f"predict the held-out records worse with it ({numbers})" if c.val_r2 < ref - 5e-4 else
                    f"do not confirm it beyond noise ({numbers})")  # "worse" where the quoted R^2 shows it
            if c.detail.get("refused_as_resonance_on_J_alone"):  # _resonance_on_j_alone refused it, not VAL
                held = (f"support it in the frequency-domain fit alone (its output-error refit at p "
                        f"{c.detail['td_p_output_error']:.2g}), short of the {c.detail['level_j_alone']:.2g} a "
                        f"resonance picked from the band needs there ({numbers})")
            mode = c.params.get("structural_mode", {}).get("freq_hz")
            where = "" if mode is None else f" (for a resonance, energy near {mode:.3g} Hz)"
            lines.append(
                f"Unconfirmed: the identification records support {_params_text(c)} (p {c.train_p:.2g}), but they "
                f"{held}. It is no verdict; held-out records that exercise it more{where} would settle it."
            )
        if self.suggestion:
            lines.append(self.suggestion)
        for name, why in self.skipped.items():
            lines.append(f"Skipped {name}: {why}")
        return "\n".join(lines)


def _refitted_pair(c: CandidateScore, structure: CandidateScore | None) -> tuple[float, float] | None:
    """``(freq_hz, zeta_p)`` of the airframe pair a resonance ``c`` fitted beside a structure
    finding holds (:func:`fit_resonance_beside_pair` refits it), where that differs from the
    structure finding's own by more than 1 % in either; else ``None``."""
    if structure is None or not c.detail.get("second_pole_pair") or "pair_freq_hz" not in c.detail:
        return None
    sm = structure.params["structural_mode"]
    f, z = c.detail["pair_freq_hz"], c.detail["pair_zeta_p"]
    if abs(f / sm["freq_hz"] - 1.0) <= 0.01 and abs(z / sm["zeta_p"] - 1.0) <= 0.01:
        return None
    return f, z


def _against_null_refit(c: CandidateScore) -> bool:
    """Whether ``c`` was scored on the held-out records against the null output-error refit
    (its z-score and the effect it must show): the nonlinear candidates, the
    cross-coupling, and a linear candidate decided by its time-domain check; the others
    against the frequency-domain base."""
    return c.effects[0] in NONLINEAR or c.effects == ("cross_coupling",) or bool(c.detail.get("time_domain_path"))


def _params_text(c: CandidateScore) -> str:
    """A candidate's fitted parameters with their 1-sigma, for the summary."""
    parts = []
    for e in c.effects:
        for p, v in c.params[e].items():
            s = c.sigma.get(e, {}).get(p, float("nan"))
            if p == "delay_s":
                text = f"{e} = {1e3 * v:.1f} ms (+-{1e3 * s:.1f})"  # a 0.4 ms bound is no "+-0"
            else:
                text = f"{e} {p} = {v:.3g} (+-{s:.2g})"
            lag = AIRFRAME_LAGS.get(e)  # (parameter, coordinate, detail stem) of a lag read two ways
            if lag is not None and lag[0] == p and f"{lag[2]}_airframe_s" in c.detail:
                pair_s = c.detail[f"{lag[2]}_pair_s"]
                if c.detail.get("named_between_airframes"):  # _lead_lag_reading
                    text += f", the lead-lag airframe's reading (the extra pole pair read {1e3 * pair_s:.1f} ms)"
                else:
                    lo, hi = sorted((pair_s, c.detail[f"{lag[2]}_airframe_s"]))
                    text += f", the centre of the {1e3 * lo:.1f}-{1e3 * hi:.1f} ms two airframe models read"
            parts.append(text)
    return ", ".join(parts)


def _unconfirmed(ranking: Sequence[CandidateScore], verdict: str, alpha: float) -> tuple[str, ...]:
    """With a ``none`` verdict, the candidates whose identification evidence passes at
    ``alpha`` (``train_p`` below it: ``J``'s F-test, the output error's, or the off-axis
    gain's) while the held-out records refuse them (``z_min``, ``min_gap`` of
    :class:`DiagnoseSettings`), in ranking order; otherwise none.

    The held-out records decide the verdict, and they can refuse a real effect where the
    base carries model-form error near it: on an R-50 the paper model with one extra pole
    pair predicts the held-out records worse with the true resonance added (seed-137
    case_003, 8.3 Hz: R^2 0.987 -> 0.986, and ``J`` on those records 6.6 -> 23), and with a
    rate limit refitted to within 4 % of the true rate (seed-131 case_003: R^2 0.991 ->
    0.979).  The summary names such a candidate instead of keeping it behind ``none``; not
    a broad pair (:func:`_broad_pairs_refused`), which was refused as no resonance at all,
    nor an effect switched off (:func:`_switched_off_refused`), whose evidence is its base's."""
    if verdict != "none":
        return ()
    return tuple(c.effects[0] for c in ranking if not c.beats_noise and c.train_p < alpha
                 and not c.detail.get("broad_pair_no_resonance") and not c.detail.get("effect_switched_off"))


_SAME_INPUT_OUTPUT = {"sensor_lag": "rotor_flapping", "rotor_flapping": "sensor_lag"}
"""Effects whose augmented models span the same input-output family once the paper
parameters are refitted (``test_sensor_lag_and_rotor_flapping_are_the_same_input_output_family``)."""


def separation_suggestion(ranking: Sequence[CandidateScore], margin: float = 0.1,
                          settled: Collection[frozenset] = ()) -> str:
    """The report's advice on telling the top candidate from its rivals ("" when none).

    When the top two both beat noise and score within ``margin`` (the score is a
    log-likelihood ratio per effective point plus the gap closed: a difference below 0.1
    is within what one more flight would change), it names the pair and the excitation
    of :data:`SEPARATING_EXCITATION` that separates them.  A top candidate of
    :data:`_SAME_INPUT_OUTPUT` carries its twin's caveat whatever the scores: the two
    fit the same responses, so a score difference between them is the fits' luck, not
    evidence.  Pairs in ``settled`` (the two lags, where the gyro path was tested) the
    data have told apart already: no advice for them.
    """
    if not ranking or not ranking[0].beats_noise:
        return ""
    a = ranking[0].effects[0]
    if len(ranking) >= 2 and ranking[1].beats_noise and ranking[0].score - ranking[1].score < margin:
        b = ranking[1].effects[0]
        if frozenset({a, b}) in settled:
            return ""
        tip = SEPARATING_EXCITATION.get(frozenset({a, b}))
        return f"{a} and {b} explain the data almost equally well" + (
            f"; {tip}." if tip else "; fly a wider-band, two-amplitude sweep to separate them."
        )
    twin = _SAME_INPUT_OUTPUT.get(a)
    if twin is None or frozenset({a, twin}) in settled:
        return ""
    return f"{a} fits best, but {twin} would explain the same data; {SEPARATING_EXCITATION[frozenset({a, twin})]}."


def _amplitude_agreement(name: str, amp: AmplitudeDependence) -> float:
    """How well the amplitude test matches a servo nonlinearity, in [-1, 1]: 0 when the
    records cannot test it, -1 when the response does not change with amplitude, 1 when
    it changes the way the effect predicts (backlash costs small inputs most, so the gain
    rises with amplitude; a rate limit or saturation costs large inputs most, so it
    falls), -0.5 when it changes the other way."""
    if not amp.tested:
        return 0.0
    if not amp.dependent:
        return -1.0
    rises = amp.high_minus_low_db > 0.0
    return 1.0 if rises == (name == "backlash") else -0.5


_MODE_AGREEMENT_ZETA_P = 0.2
"""The largest fitted pole damping whose ``structural_mode`` counts as the lightly damped
resonance step 2 detects (the vocabulary's draws reach 0.08; a broad pole pair that
mimics a lag fits 0.2-0.7, seed-41 development cases)."""
_MODE_AGREEMENT_FACTOR = 1.25
"""How far (a factor) a fitted mode's frequency may lie from the detected resonance."""
_Z_HI_SECOND_PAIR = np.r_[_Z_HI[:4], math.log(_MODE_AGREEMENT_ZETA_P), _Z_HI[5]]
"""The top of the box of a resonance fitted beside a structure finding's pole pair: a
lightly damped one.  A broad pair there refits that pair's model-form error instead
(seed-131 R-50 cases 031 and 032, 15.4 and 13.0 Hz modes: 3.1 and 3.5 Hz at pole damping
0.5 and 0.43)."""


_RESONANCE_BAND_MARGIN = 0.05
"""How far (a fraction) outside the vocabulary's frequency range (``structural_mode``'s
8-30 Hz) a fitted resonance may lie and still count as one of its resonances
(:func:`_resonance_in_box`).  The resonances the relaxed routes found on the stored blind
draws 311-353 were fitted within 2.9 % of their truth (9.65 Hz for 9.38), none below
8.02 Hz."""


def _resonance_in_box(mode: Mapping[str, float]) -> bool:
    """Whether a ``structural_mode`` refitted by output error on the paper model alone (from
    :func:`_time_domain_mode_starts` too) is a resonance whose evidence is the matched
    filter's (:func:`jaxgwo._diagnose_which.matched_filter_z`, :math:`z^2` against
    :math:`\\chi^2_3`) rather than the output error's F-test: a peak at least the
    vocabulary's least (zero over pole damping 0.1 / 0.08), pole damping at most
    :data:`_MODE_AGREEMENT_ZETA_P`, inside the box (no edge of :data:`_Z_LO`,
    :data:`_Z_HI`), and a frequency within the vocabulary's range
    (:data:`_RESONANCE_BAND_MARGIN` beyond it).

    The same test makes a ``J`` fit a resonance that needs the held-out records only not to
    contradict it (:func:`_resonance_found_by_j`, :func:`_same_resonance`,
    :func:`_matched_filter_alone`): those routes exist because the held-out 3-2-1-1s and
    doublets put little power above 8 Hz, where the vocabulary's resonances lie.  Below
    that band the multisteps do excite a mode, so it must close a positive gap there as
    every other ``structural_mode`` does.  Fresh seed 353's case_027 (paper plant, no
    effect) was called ``structural_mode`` by a ``J`` fit at 6.35 Hz (pole damping 0.067,
    zeros 0.10; p 5.5e-4, held-out z -1.22, gap -0.041) on the ``J`` route; on the stored
    rankings of 311-353 every other fit these routes admitted lay at 8.02 Hz or above, on
    a true resonance, and none of them moves.

    A lightly damped mode's output lies in a narrow band above 8 Hz where the gusts are
    weak; the F-test's effective samples come from the residual's correlation time, set by
    the gusts at low frequency, and miss it.  On the stored blind runs of seeds 131, 149,
    151 and 157 (their 32 ``structural_mode`` and 32 ``none`` cases rediagnosed with both
    tests recorded, ``/work/runs/s37``): the refit found two true modes within 2 % that the
    F-test refused and the matched filter passes (seed-157 case_031, 13.5 Hz for 13.8: p
    0.0068 against 7e-9; seed-131 case_051, 11.4 for 11.5: p 0.013 against 6e-6), both
    confirmed on the held-out records; on the 25 ``none`` cases whose mode was refitted on
    the paper model alone, the matched filter's :math:`z^2` averaged 3.0 (:math:`\\chi^2_3`:
    3), its largest :math:`z` 2.98 (the threshold at ``alpha`` 1e-3: 4.03).  A notch or a
    vanishing pair, and a fit on the box's edge (45 Hz, pole damping 0.01), are no
    resonance of the vocabulary and keep the F-test, as do broadband candidates (delay,
    lags): on a seed-157 R-50 ``none`` case (049) a delay, a flapping lag and a gyro filter
    each passed the matched filter (z 3.9, p 8e-5 for their one parameter) and were
    confirmed on the held-out records (z 1.08)."""
    hi_p = EFFECTS["structural_mode"].ranges[1][1]
    lo_z = EFFECTS["structural_mode"].ranges[2][0]
    peak = mode["zeta_z"] >= (lo_z / hi_p) * mode["zeta_p"] and mode["zeta_p"] <= _MODE_AGREEMENT_ZETA_P
    lo_f, hi_f = EFFECTS["structural_mode"].ranges[0]
    in_band = lo_f * (1.0 - _RESONANCE_BAND_MARGIN) <= mode["freq_hz"] <= hi_f * (1.0 + _RESONANCE_BAND_MARGIN)
    return bool(peak and in_band and not _on_box_edge(mode, _Z_HI[3:6]))


def _j_finds(sc: CandidateScore, alpha: float) -> bool:
    """Whether a ``J`` fit's own identification evidence passes, whatever the held-out
    records say: its F-test at ``alpha`` and its BIC."""
    return sc.train_p < alpha and sc.delta_bic < 0.0


def _resonance_found_by_j(effects: Sequence[str], params: Mapping, sc: CandidateScore, alpha: float) -> bool:
    """Whether the ``J`` fit of a ``structural_mode`` (its ``params``, score ``sc``) is a
    resonance of the vocabulary's shape (:func:`_resonance_in_box`) that ``J`` finds on its
    own evidence (:func:`_j_finds`: F-test at ``alpha`` and BIC; a fit on an edge of its box
    beside a structure finding's pair has no evidence, :func:`_on_box_edge`), with complex
    zeros (zero damping below 1: real zeros make it a pole pair the paper model lacks,
    :class:`DiagnoseSettings`' ``structure_zeta_z``).  Its held-out records then need only
    not contradict it (``z_min``, ``min_gap``), as a linear ``J`` fit's, instead of closing
    a positive gap.

    The held-out 3-2-1-1s and doublets carry 0.7-23 % of the identification records' input
    energy within 20 % of the fitted frequency (Welch, on the 39 resonance-shaped ``J`` fits
    at p < 1e-3 of blind seeds 199-269, found or not), so what a resonance's fit does on
    them is mostly what its refitted paper parameters do.  The positive gap was set against
    a ``J`` bump a ``none`` case fitted at p 1e-4 (seed 41, :class:`DiagnoseSettings`).
    Replayed on the stored rankings of blind seeds 199-269 (576 cases), this floor admits
    two true resonances, both on R-50 plants beside the structure finding's pair, and no
    case without one: seed-223 case_020 (10.14 Hz for 10.11, ``J`` 7.20 -> 3.71 at p 1e-5,
    held-out z -1.87, gap -0.034) and seed-269 case_007 (14.45 Hz for 13.69, p 3e-12, z
    -0.95, gap -0.12, the verdict a flapping lag).  The two other such fits the held-out
    records refused stay refused by ``z_min``: a paper resonance (233/020, z -2.37) and a
    paper flapping lag's broad mode (199/002, z -2.48).  Rediagnosed on this rule, 223/020
    and 269/007 answer ``structural_mode`` (10.14 and 14.45 Hz)."""
    return bool(
        tuple(effects) == ("structural_mode",)
        and _j_finds(sc, alpha)
        and _resonance_in_box(params["structural_mode"])
        and params["structural_mode"]["zeta_z"] < 1.0
    )


def _held_out_floor(settings: DiagnoseSettings, effects: Sequence[str], time_domain: bool, confirm: bool,
                    as_linear: bool = False) -> tuple[float, float]:
    """``(z_min, min_gap)`` the held-out records must beat for a candidate of ``effects``.
    A linear ``J`` fit needs only not to be contradicted (``z_min``, ``min_gap``); a
    time-domain candidate that must be confirmed (``confirm``) needs ``z_min_time``; any
    time-domain candidate and any ``structural_mode`` need a positive gap (the docstring
    of :class:`DiagnoseSettings`).  ``as_linear`` (a resonance two tests find,
    :func:`_same_resonance`, or one ``J`` finds on its own, :func:`_resonance_found_by_j`)
    takes a linear ``J`` fit's floor."""
    if as_linear:
        return settings.z_min, settings.min_gap
    z_min = settings.z_min_time if time_domain and confirm else settings.z_min
    min_gap = 0.0 if time_domain or "structural_mode" in effects else settings.min_gap
    return z_min, min_gap


def _same_resonance(sc_j: CandidateScore, mode_td: Mapping[str, float], alpha: float) -> bool:
    """Whether a ``structural_mode``'s ``J`` fit (score ``sc_j``) found, on its own
    evidence, the resonance its output-error refit ``mode_td`` found by the matched filter:
    the ``J`` fit passes its F-test at ``alpha`` and its BIC, is a resonance of the
    vocabulary (:func:`_resonance_in_box`), and the refit's frequency lies within its
    half-power half-width (pole damping times frequency) of the ``J`` fit's.

    Two independent tests on the identification records then agree on one mode (``J``
    weights the response's coherent points, the matched filter the output's residual), and
    the refit, like a linear candidate found on ``J``, needs the held-out records only not
    to contradict it (``z_min``, and a gap above ``min_gap``: the positive gap asked of any
    other ``structural_mode`` guards against a local bump one test takes for a mode)
    instead of confirming it (``z_min_time``).  Seed-181 case_063 (an 8.50 Hz mode, pole
    damping 0.028): ``J`` 8.53 Hz at p 6e-13, the refit 8.50 Hz and 0.027 at matched-filter
    z 13.9, held-out z 1.17 and gap -0.009, so it was refused for that gap and the verdict
    was a 58 ms flapping lag closing 0.2 % of it; the true model itself scores held-out z
    0.6 there (the multisteps hardly excite 8.5 Hz).  On the stored rankings of the eleven
    fresh draws 131-191 no other refit of this route had a gap below 0.03.
    The ``J`` fit's own held-out check may fail where its paper parameters do not transfer
    while the refit's do, and the null refit can leave the held-out records nothing to
    confirm: seed-173 case_020 (paper plant, a 9.60 Hz mode at pole damping 0.066, zeros
    0.133): ``J`` 14.8 -> 1.9 at 9.71 Hz (p 8e-17), held-out z -2.09 against the nominal;
    the refit 9.63 Hz, 0.074, 0.145, matched-filter z 20.3, held-out R^2 0.9994 where the
    null refit gives 0.99937 and the true model 0.9992 (z 0.46, short of ``z_min_time``), so
    the verdict was ``none``.  On the stored rankings of the fresh draws 131-173 no other
    case meets this: the nearest, seed-163 case_025 (a 10.7 Hz mode called ``time_delay``),
    has its refit at 10.56 Hz, 0.54 Hz from the ``J`` fit's 11.10 (half-width 0.51), and
    closes no gap; the other ``J`` fits refused with a passing refit were pole pairs of
    damping 0.28-0.47 or on the box's 45 Hz edge (lags and rate limits)."""
    mode_j = sc_j.params["structural_mode"]
    return bool(
        _j_finds(sc_j, alpha)
        and _resonance_in_box(mode_j)
        and abs(mode_td["freq_hz"] - mode_j["freq_hz"]) <= mode_j["zeta_p"] * mode_j["freq_hz"]
    )


def _resonance_on_j_alone(p_j: float, p_time_domain: float | None, alpha: float, alpha_j_alone: float) -> bool:
    """Whether a ``structural_mode`` fitted to ``J`` on the paper model alone is refused
    for resting on ``J`` alone near its threshold: its output-error refit (or, where that
    refit is a resonance of the box, its matched filter: ``td_p_output_error``,
    ``p_time_domain``) finds nothing at ``alpha``, and its ``J`` F-test (``p_j``) does not
    pass ``alpha_j_alone`` (:class:`DiagnoseSettings`: ``alpha_resonance_j_alone``).
    Without a time-domain check (``None``) it is not refused.

    The F-test reads ``J`` at the fitted frequency, which the fit chose from the band
    8 Hz to the sweeps' top: the best of many frequencies, so near ``alpha`` it
    understates chance (a look-elsewhere effect; the box spans some ten resolvable
    frequencies, whence ``alpha`` / 10).  Five paper plants without an effect were called
    ``structural_mode`` so in the fresh draws 131-603 (229/052, 283/028, 459/054; 541/054
    at ``J`` p 6.5e-4 and output-error p 0.86; fresh seed 603's case_053 at 8.6 Hz, ``J``
    p 8.1e-4, output-error p 0.995, held-out z 2.81 on a gap of 0.068).  In the stored
    rankings of draws 593-605 (504 cases) every true paper resonance that beat noise had
    ``J`` p 1.3e-8 or less, and no other candidate falls under the rule; the two true
    modes session 74 found carried by ``J`` alone, re-simulated, had 7.5e-12 (545/041,
    paper) and 9.8e-9 (547/071, an R-50's beside its pair, where the rule does not act).
    Rediagnosed with it, 541/054 and 603/053 answer ``none``.  Set on those two, in
    sample.  Out of sample, fresh seed 607 (diagnosed before it): of its stored
    candidates it refuses two paper false alarms, 027 and 055 (``J`` p 4.1e-4 and
    1.2e-4, output-error p 0.13 and 0.15), and nothing else; rediagnosed, 027 answers
    ``none`` and 055 ``time_delay`` (a delay ``J`` passes at 7.5e-4, ranked second
    before)."""
    return p_time_domain is not None and not p_time_domain < alpha and not p_j < alpha_j_alone


def _matched_filter_alone(matched: bool, agree: bool, p_matched: float, alpha_resonance: float) -> bool:
    """Whether a resonance refitted by output error on the paper model alone, whose
    evidence is the matched filter's (``matched``: :func:`_resonance_in_box`; its p
    ``p_matched``) and which ``J`` does not find with it (``agree`` false:
    :func:`_same_resonance`), lies so far beyond noise (``p_matched`` below
    ``alpha_resonance``) that the held-out records need only not contradict it: ``z_min``
    and a positive gap (:func:`_held_out_floor` unconfirmed) instead of ``z_min_time``
    (:class:`DiagnoseSettings`: ``alpha_resonance``)."""
    return bool(matched and not agree and p_matched < alpha_resonance)


def _refit_may_stand_in(j_mode: Mapping[str, float], td_mode: Mapping[str, float]) -> bool:
    """Whether the output-error refit of a resonance beside a structure finding's pole pair
    (``td_mode``) may stand in for its ``J`` fit (``j_mode``): only where neither stopped
    on an edge of the box (:func:`_on_box_edge`).  The refit starts from the ``J`` fit, so
    one that stepped just inside an edge the ``J`` fit sat on is that fit's model-form
    error still: fresh seed 511's case_052, an R-50 `none`, was named ``structural_mode``
    by a refit at 4.45 Hz, pole damping 0.185, beside a ``J`` fit on the 0.2 cap.  Over
    the stored draws 499-513, 35 ``J`` fits on an edge had an output-error refit that beat
    noise; 32 of those refits sat on an edge themselves, the other three were a flapping
    lag's, a delay's and that `none`'s, and none of the 35 was a resonance's (511/051's,
    at 5.8 Hz for a true 11.5 Hz mode, sat on the 0.2 cap)."""
    return not (_on_box_edge(j_mode) or _on_box_edge(td_mode))


def _on_box_edge(mode: Mapping[str, float], hi: np.ndarray = _Z_HI_SECOND_PAIR[3:6]) -> bool:
    """Whether a resonance fitted beside a structure finding's pole pair (its ``params``)
    stopped on an edge of its box (:data:`_Z_LO`, and ``hi``, the log tops of frequency,
    pole and zero damping: :data:`_Z_HI_SECOND_PAIR`'s by default; :func:`_resonance_in_box`
    passes :data:`_Z_HI`'s).  There it is no resonance but a refit of the held pair's
    model-form error.  On the R-50 cases of seeds 113 and 131 every such fit that beat
    noise was one: at 3 Hz and pole damping 0.2 (seed-113 case_068, a flapping lag named
    ``structural_mode`` at output-error p 6e-16), or at zero damping 1.5 on the three
    long delays; the fits near a true resonance lay inside (13.5 Hz for 13.0, 11.3 for
    13.1)."""
    z = np.log(_mode_tuple(mode))
    return bool(np.any(z <= _Z_LO[3:6] + 1e-3) or np.any(z >= hi - 1e-3))


def _mode_tuple(mode: Mapping[str, float]) -> tuple[float, float, float]:
    """A ``structural_mode``'s ``(freq_hz, zeta_p, zeta_z)``, as :attr:`ModelSpec.fixed_modes` holds it."""
    return (mode["freq_hz"], mode["zeta_p"], mode["zeta_z"])


def _pair_in_resonance_slot(mode: Mapping[str, float], pair: Sequence[float], structure_zeta_z: float) -> bool:
    """Whether a joint fit's resonance (its ``params``, as :func:`_on_box_edge`) is the structure
    finding's pole ``pair`` moved into the resonance's slot: real zeros, as the structure
    step names a pair (zero damping above ``structure_zeta_z``), at a frequency within the
    pair's half-power half-width (its pole damping times its frequency).  The other slot
    then holds another pair, not the resonance the candidate names (session 88: a 9 Hz
    structure pair at pole damping 0.15, zeros 1.5, came back as the resonance, 9.15 Hz,
    zeros 1.23, beside a 1.44 Hz pair that fitted the noise, ``J`` 2.28 against 2.73)."""
    return mode["zeta_z"] > structure_zeta_z and abs(mode["freq_hz"] - pair[0]) <= pair[1] * pair[0]


def fit_resonance_beside_pair(objective, x_paper: np.ndarray, pair: tuple[float, float, float], z_pair: np.ndarray,
                              key, structure_zeta_z: float = DiagnoseSettings.structure_zeta_z,
                              **kw) -> tuple[LinearFit, tuple[tuple[float, float, float]]]:
    """A resonance fitted on ``J`` beside an airframe pole pair ``pair`` (``freq_hz,
    zeta_p, zeta_z``; ``z_pair`` its effect coordinates), in the box of
    :data:`_Z_HI_SECOND_PAIR`, with the paper parameters (start ``x_paper``).  Returns the
    resonance's fit (its ``J`` is the model's with both) and the pair it lies beside.

    The pair was fitted without the resonance and bent toward it; held there, the two do
    not fit together.  So the resonance is fitted beside the pair held, then the pair
    refitted beside the resonance held (the structure step's box, from where it was), then
    the resonance beside that pair, and the last two are kept where they fit ``J`` better.
    That alternation stays in the basin the held pair bent the resonance into, so the pair
    is also refitted *with* the resonance from a grid of its frequency
    (:func:`jaxgwo._diagnose_which.joint_pair_resonance_scan`); where that fits ``J``
    better with a resonance inside the box (:func:`_on_box_edge`), the resonance is fitted
    again beside the pair it found, held, and kept where it fits ``J`` better still and
    inside the box (fresh seed 651's R-50 case_000, a 9.67 Hz mode at pole damping 0.025:
    8.77 Hz on the 0.2 cap, ``J`` 6.85, before; 9.68 Hz, 0.036, ``J`` 5.63 with it).  A joint
    fit on an edge is the pair's model-form error again and is not taken: without that
    test it displaced two right resonances of the stored draws, 627/022 (10.53 Hz for 10.4,
    ``J`` 8.2) by 5.54 Hz on the damping cap (6.1), and 629/015 (15.8 Hz for 14.3, 3.7) by
    16.2 Hz with zeros on the cap (3.2).
    On ``J`` the pair's refit adds no parameter to the F-test's count: the base fitted it
    on ``J`` as well (the time-domain check, whose null holds the pair, holds it too).
    Seed-137 case_003 (R-50, 8.31 Hz): ``J`` 6.42 -> 5.89, and the held-out R^2 against
    the pair alone 0.9868 -> 0.9851 (z -2.2, refused) before, 0.9870 (z 1.4) after; the
    resonance 8.31 Hz, pole damping 0.041, zeros 0.080 for the true 0.046 and 0.110.
    Nor is a joint fit taken whose resonance is ``pair`` itself moved into the resonance's
    slot (:func:`_pair_in_resonance_slot`, real zeros above ``structure_zeta_z``,
    :class:`DiagnoseSettings`').
    ``kw``: :func:`fit_linear_candidates`'s ``wolves``, ``iterations``, ``dependence_factor``."""
    own = [("structural_mode",)]
    fixed = (tuple(pair),)
    (f,) = fit_linear_candidates(with_fixed_modes(objective, fixed), x_paper, own, key, z_hi=_Z_HI_SECOND_PAIR, **kw)
    (g,) = fit_linear_candidates(with_fixed_modes(objective, [_mode_tuple(f.params["structural_mode"])]), f.x[:5], own,
                                 jax.random.fold_in(key, 1), effect_seed=z_pair, z_hi=_Z_HI_STRUCTURE,
                                 z_lo=_Z_LO_STRUCTURE, **kw)  # fmt: skip
    refitted = (_mode_tuple(g.params["structural_mode"]),)
    (h,) = fit_linear_candidates(with_fixed_modes(objective, refitted), g.x[:5], own, jax.random.fold_in(key, 2),
                                 effect_seed=f.x[5:], z_hi=_Z_HI_SECOND_PAIR, **kw)  # fmt: skip
    best = min(((f, fixed), (h, refitted)), key=lambda fit: fit[0].cost_J)
    # the pair refitted with the resonance from a grid of the resonance's frequency
    # (joint_pair_resonance_scan): the alternation above keeps the basin the held pair bent
    # the resonance into; where the joint fit is better and a resonance (inside the box:
    # _on_box_edge) it is fitted again as above, beside its pair held, for the resonance's
    # bounds and J
    j_joint, x_joint = joint_pair_resonance_scan(objective, x_paper, pair, _Z_HI_SECOND_PAIR[3:6])

    def taken(mode: Mapping[str, float]) -> bool:  # a resonance inside the box, not the pair moved into its slot
        return not _on_box_edge(mode) and not _pair_in_resonance_slot(mode, pair, structure_zeta_z)

    z_joint = None if not j_joint < best[0].cost_J else np.r_[_Z_NEUTRAL[:3], x_joint[8:11]]  # the resonance
    if z_joint is not None and taken(effect_params_from_z("structural_mode", z_joint)):
        joint = (tuple(float(v) for v in np.exp(x_joint[5:8])),)
        (k,) = fit_linear_candidates(with_fixed_modes(objective, joint), x_joint[:5], own, jax.random.fold_in(key, 3),
                                     effect_seed=z_joint, z_hi=_Z_HI_SECOND_PAIR, **kw)  # fmt: skip
        if k.cost_J < best[0].cost_J and taken(k.params["structural_mode"]):
            best = (k, joint)
    return best


def fit_flybar_and_resonance(objective, x_pair: np.ndarray, key, **kw) -> tuple[LinearFit, LinearFit]:
    """From a structure finding's fit ``x_pair`` (paper parameters, then effect
    coordinates), the airframe pair refitted below the vocabulary's floor
    (:func:`fit_beside_flybar`) and a resonance fitted beside it
    (:func:`fit_resonance_beside_pair`).  Returns both fits; the second's ``J`` is the
    model's with the pair and the resonance.  ``kw``: :func:`fit_linear_candidates`'s
    ``wolves``, ``iterations``, ``dependence_factor``."""
    (low,) = fit_beside_flybar(objective, x_pair[:5], [("structural_mode",)], x_pair[5:], key, **kw)
    res, _pair = fit_resonance_beside_pair(objective, low.x[:5], _mode_tuple(low.params["structural_mode"]), low.x[5:],
                                           jax.random.fold_in(key, 1), **kw)  # fmt: skip
    return low, res


def _mode_agreement(fm: FrequencyMismatch, params: dict | None) -> float:
    """1 when step 2 detected a narrow resonance and the fitted ``structural_mode`` is it:
    lightly damped (pole damping at most :data:`_MODE_AGREEMENT_ZETA_P`) and within a
    factor :data:`_MODE_AGREEMENT_FACTOR` of the resonance's frequency; else 0.  Any
    detected resonance counted before, whatever the fit: a broad pole pair standing in
    for a 25.8 Hz gyro filter (pole damping 0.68) won a seed-79 case by that margin."""
    if fm.resonance_hz is None or not params:
        return 0.0
    light = params["zeta_p"] <= _MODE_AGREEMENT_ZETA_P
    near = abs(math.log(params["freq_hz"] / fm.resonance_hz)) <= math.log(_MODE_AGREEMENT_FACTOR)
    return 1.0 if light and near else 0.0


def _agreement(name: str, fm: FrequencyMismatch, amp: AmplitudeDependence, off: ResidualTests | None,
               params: dict | None = None) -> float:
    """How well an effect's expected signature matches the step-2 detectors, in [-1, 1];
    ``params`` are the effect's fitted parameters (read for ``structural_mode``)."""
    lag = fm.equivalent_delay_s > 2.0 * fm.equivalent_delay_sigma_s and fm.equivalent_delay_s > 0.002
    if name in NONLINEAR:
        return _amplitude_agreement(name, amp)
    if name == "cross_coupling":
        if off is None:
            return 0.0
        return 1.0 if abs(off.input_residual_peak) > off.xcorr_bound else -0.5
    if name == "structural_mode":
        return _mode_agreement(fm, params)
    if name == "time_delay":
        return 1.0 if lag and abs(fm.magnitude_slope_db_per_decade) < 1.0 else (0.5 if lag else 0.0)
    # sensor_lag, rotor_flapping: phase lag with a magnitude trend
    return 1.0 if lag and abs(fm.magnitude_slope_db_per_decade) >= 1.0 else (0.5 if lag else 0.0)


_LAGS = ("sensor_lag", "rotor_flapping")


def _best_first(c: CandidateScore) -> float:
    """Sort key of the ranking: highest score first, a NaN score (a refit that simulated
    nothing finite) last; a NaN key would leave Python's sort out of order."""
    return -c.score if math.isfinite(c.score) else math.inf


_TAIL_LAG_OVER_DELAY_P = 10.0
"""How many times a ``time_delay``'s identification p the lags' may be, in the tail of
candidates that do not beat noise, for the lags to go ahead of it (:func:`_failing_by_evidence`)."""


def _failing_by_evidence(ranking: Sequence[CandidateScore], filter_held: bool | None = None) -> tuple[CandidateScore, ...]:
    """``ranking`` (best first) with its tail of candidates that do not beat noise ordered by
    their identification evidence: the smallest ``train_p`` first (``J``'s F-test, the
    output error's or the off-axis gain's, as :func:`_unconfirmed` reads it), ties in their
    order.  The candidates that beat noise, the verdict among them, keep their places.

    The two lags of :data:`_SAME_INPUT_OUTPUT` share the smaller of their two p (they fit
    the same responses, so their p differ by rounding) and stand together; where the gyro
    path was tested (``filter_held`` not ``None``: :func:`_gyro_filter_held`), the
    ``sensor_lag`` first if it holds a filter and the ``rotor_flapping`` first if not, as
    :func:`_gyro_path_order` orders them when they pass; otherwise in their order.  A lag
    the gyro path refuted, and a p that is not a number, go last.  A ``time_delay`` ahead
    of the lags whose p is no more than :data:`_TAIL_LAG_OVER_DELAY_P` times smaller has
    them go ahead of it, as :func:`_lag_over_delay` and :func:`_lag_over_short_delay` move
    passing lags: no cyclic input separates a lag from a short delay, and a delay the
    data show is seldom left below noise.

    The score that orders the ranking adds the held-out gap to the ``J`` evidence, which
    for a candidate the held-out records did not confirm is mostly their noise.  Replayed on
    the stored diagnoses of fresh draws 373-485 (``benchmarks/blind_tail_order.py``; 2368
    effect cases, 312 answered ``none``) the truth led that tail on 88 of the 312 in score
    order and on 138 by p alone, and top-2 over the whole ranking (the verdict, then
    ``none``, then this tail) rose from 2116 to 2166: paper resonances, which the held-out
    records excite little, 163 -> 209; on the R-50 461 -> 460.  A delay led the tail by p
    on 48 of those ``none`` verdicts, 44 of them flapping lags (the lags' p 1.0-3.4 times
    the delay's) and one an R-50 delay (15.2 times); with the lags over it and in the gyro
    path's order, 2215 (paper 25 more, R-50 24 more, none lost).  In sample: the factor
    lies between 3.4 and 15.2 on one delay.  It moves no verdict, and the headline top-2
    counts only candidates that beat noise; ``combined_top2`` of a ``none`` verdict and the
    summary's "Unconfirmed" leads follow the new order."""
    ranking = tuple(ranking)
    last = max((i for i, c in enumerate(ranking) if c.beats_noise), default=-1)
    head, tail = ranking[: last + 1], ranking[last + 1 :]

    def p_of(c: CandidateScore) -> float:
        return c.train_p if math.isfinite(c.train_p) and not c.detail.get("refuted_by_gyro_path") else math.inf

    p = {c.effects: p_of(c) for c in tail}
    for c in tail:
        twin = (_SAME_INPUT_OUTPUT.get(c.effects[0]),) if len(c.effects) == 1 else None
        if twin in p and p[c.effects] < math.inf and p[twin] < math.inf:
            p[c.effects] = p[twin] = min(p[c.effects], p[twin])
    tail = [tail[i] for i in sorted(range(len(tail)), key=lambda i: (p[tail[i].effects], i))]
    lags = [c for c in tail if c.effects in ((e,) for e in _LAGS) and p[c.effects] < math.inf]
    if not lags:
        return (*head, *tail)
    if filter_held is not None:
        lags.sort(key=lambda c: c.effects != (("sensor_lag",) if filter_held else ("rotor_flapping",)))
    rest = [c for c in tail if not any(c is x for x in lags)]
    at = next(i for i, c in enumerate(tail) if c is lags[0] or c is lags[-1])  # the lags' place among the rest
    delay = next((i for i, c in enumerate(rest[:at]) if c.effects == ("time_delay",)), None)
    if delay is not None and p[lags[0].effects] <= _TAIL_LAG_OVER_DELAY_P * p[rest[delay].effects]:
        at = delay
    return (*head, *rest[:at], *lags, *rest[at:])


def _passing_delay_at_head(ranking: tuple[CandidateScore, ...]) -> bool:
    """Whether ``ranking`` (best first) is headed by a ``time_delay`` that beats noise
    (:func:`_lag_over_delay`, :func:`_lag_over_short_delay`)."""
    return bool(ranking) and ranking[0].effects == ("time_delay",) and ranking[0].beats_noise


def _lag_over_delay(ranking: Sequence[CandidateScore], margin: float) -> tuple[CandidateScore, ...]:
    """``ranking`` (best first) with the passing lags that score within ``margin`` of a
    ``time_delay`` at its head moved ahead of it, in their order (:class:`DiagnoseSettings`,
    ``lag_over_delay``; each one's ``detail`` then records the delay's lead as
    ``ranked_over_delay_by``); otherwise unchanged.  Both lags move: no cyclic input
    separates them (:data:`SEPARATING_EXCITATION`)."""
    ranking = tuple(ranking)
    if not _passing_delay_at_head(ranking):
        return ranking
    top = ranking[0].score
    lags = _passing_within(ranking, _LAGS, margin)
    if not lags:
        return ranking
    return _ahead(ranking, lags, lambda c: {"ranked_over_delay_by": top - c.score})


_LEVEL_ON_STRUCTURE = (("rotor_flapping",), ("time_delay",))
"""The candidates whose ``J`` F-test on top of a structure finding is read at
``alpha_lag_on_structure`` (:class:`DiagnoseSettings`)."""
_DELAY_FLOOR_S = EFFECTS["time_delay"].ranges[0][0] * (1.0 - _RESONANCE_BAND_MARGIN)
"""The shortest fitted ``time_delay`` that counts as one of the vocabulary's delays (10-80
ms), with :data:`_RESONANCE_BAND_MARGIN` below its floor: on top of a structure finding a
shorter one is a lag's imitation (:func:`_lag_over_short_delay`)."""
_DELAY_RANGE_MS = "{:g}-{:g} ms".format(*(1e3 * v for v in EFFECTS["time_delay"].ranges[0]))
"""The vocabulary's delays, as the summary names them beside :data:`_DELAY_FLOOR_S`."""


def _lag_over_short_delay(ranking: Sequence[CandidateScore]) -> tuple[CandidateScore, ...]:
    """``ranking`` (best first, on top of a structure finding) with the passing lags moved
    ahead of a passing ``time_delay`` at its head that was fitted shorter than
    :data:`_DELAY_FLOOR_S`, in their order (each one's ``detail`` then records the delay as
    ``ranked_over_short_delay_s``); otherwise unchanged.

    Beside an R-50's flybar pair a flapping lag inside the rotor/fuselage loop fits ``J``
    as well as a delay of 4-10 ms, often a little better (``J`` lower by 0.05-0.9 on the
    R-50 flapping lags of the stored draws 367-441, whose lags fitted 0.7-11 ms), while
    the R-50's true delays fitted 9.1 ms (for 11.0) and 16-83 ms.  Unlike
    :func:`_lag_over_delay` (the paper model alone), no score margin: a delay shorter than
    any of the vocabulary's is no delay of it.  Both lags move, as there; the gyro path
    then orders them (:func:`_gyro_path_order`)."""
    ranking = tuple(ranking)
    if not _passing_delay_at_head(ranking):
        return ranking
    delay = ranking[0].params["time_delay"]["delay_s"]
    if not delay < _DELAY_FLOOR_S:
        return ranking
    lags = _passing_within(ranking, _LAGS, math.inf)
    if not lags:
        return ranking
    return _ahead(ranking, lags, lambda c: {"ranked_over_short_delay_s": delay})


def _nonlinearity_by_j(ranking: Sequence[CandidateScore], margin: float) -> tuple[CandidateScore, ...]:
    """``ranking`` (best first) with, where its head is a servo nonlinearity that beats
    noise, the one of lowest ``J`` among the nonlinearities that beat noise and score
    within ``margin`` of it moved to the head (:class:`DiagnoseSettings`,
    ``nonlinearity_by_j``; its ``detail`` records the head's lead as
    ``ranked_over_nonlinearity_by`` and the head's ``J`` as ``J_of_the_one_passed``);
    otherwise unchanged."""
    ranking = tuple(ranking)
    if not ranking or not ranking[0].beats_noise or len(ranking[0].effects) != 1 \
            or ranking[0].effects[0] not in NONLINEAR:
        return ranking
    head = ranking[0]
    best = min(_passing_within(ranking, NONLINEAR, margin), key=lambda c: c.cost_J, default=head)
    if best is head or not best.cost_J < head.cost_J:
        return ranking
    return _ahead(ranking, [best], lambda c: {"ranked_over_nonlinearity_by": head.score - c.score,
                                              "J_of_the_one_passed": head.cost_J})


def _passing_within(ranking: tuple[CandidateScore, ...], names: Sequence[str],
                    margin: float) -> list[CandidateScore]:
    """The single-effect candidates of ``ranking`` (best first) whose effect is one of
    ``names``, that beat noise and score within ``margin`` of its head, in their order
    (:func:`_lag_over_delay`, :func:`_nonlinearity_by_j`)."""
    top = ranking[0].score
    return [c for c in ranking
            if len(c.effects) == 1 and c.effects[0] in names and c.beats_noise and top - c.score < margin]  # fmt: skip


def _ahead(ranking: tuple[CandidateScore, ...], chosen: Sequence[CandidateScore],
           note: Callable[[CandidateScore], dict]) -> tuple[CandidateScore, ...]:
    """``ranking`` with ``chosen`` (candidates of it, in their order) moved to its head,
    each one's ``detail`` extended by ``note(c)``; the rest keep their order."""
    moved = [dataclasses.replace(c, detail=dict(c.detail) | note(c)) for c in chosen]
    return (*moved, *(c for c in ranking if not any(c is x for x in chosen)))


def _refused(c: CandidateScore, detail: Mapping[str, float] | None = None) -> CandidateScore:
    """``c`` no longer beating noise: its score less the 10 that
    :func:`jaxgwo._diagnose_which.score_candidate` takes from a candidate that fails, and
    ``detail`` added to its own."""
    return dataclasses.replace(c, beats_noise=False, score=c.score - 10.0, detail=dict(c.detail) | dict(detail or {}))


def _demoted(ranking: tuple[CandidateScore, ...], chosen: Sequence[CandidateScore],
             mark: str) -> tuple[CandidateScore, ...]:
    """``ranking`` with ``chosen`` (candidates of it) no longer beating noise
    (:func:`_refused`, ``detail[mark]`` set), placed among the failing ones by score; the
    passing ones keep their order (lags moved over a delay stay so)."""
    out = [_refused(c, {mark: 1.0}) for c in chosen]
    rest = [c for c in ranking if not any(c is x for x in chosen)]
    failing = sorted([x for x in rest if not x.beats_noise] + out, key=_best_first)
    return (*(x for x in rest if x.beats_noise), *failing)


def _nonlinearity_over_pair(ranking: Sequence[CandidateScore], pair: CandidateScore) -> tuple[CandidateScore, ...]:
    """``ranking`` (best first, on the paper model) with the nonlinearities that beat noise
    and fit ``J`` below ``pair`` moved to its head, lowest ``J`` first (each one's
    ``detail`` records ``J_over_pair_J``, its ``J`` over the pair's, and
    ``over_pair_freq_hz``, the pair's frequency; the summary says so); otherwise
    unchanged.  ``pair`` is the airframe pair the structure step would take (its ``J`` fit
    after the step's refits, :func:`diagnose`), which is then no structure finding: a servo
    nonlinearity the paper model lacks bends its response, and a broad pole-zero pair
    imitates the bend on ``J`` less well than the nonlinearity itself does.

    Paper-plant rate limits acting on 2-5 % of the identification records were taken for
    structure so, then refused on top of the pair, which had absorbed them (rediagnosed on
    38ab7bd): seed-137 case_052, a 4.9 Hz pair with real zeros at ``J`` 3.26 beside the rate
    limit at 1.11 (rate 4.85 for 4.96); 157/045, 5.81 and 2.22 (6.04 for 6.02); 167/013,
    3.25 and 2.48 (5.00 for 4.44); 173/026, 4.0 Hz, 6.79 and 2.47 (2.41 for 2.52).  Each now
    answers ``rate_limit``.  On the R-50 ``none`` cases, whose pair is the
    airframe's, a nonlinearity that beats noise on the paper model bends round the missing
    pair and fits ``J`` 16-76 times the pair's (137/008, 137/066, 157/049, 173/000,
    173/048, 173/055; on five more none beats noise), and on the R-50 rate limits of
    those seeds 12-45 times (seven of eight)."""
    ranking = tuple(ranking)
    if not pair.cost_J > 0.0:
        return ranking
    nl = sorted((c for c in ranking if len(c.effects) == 1 and c.effects[0] in NONLINEAR and c.beats_noise
                 and c.cost_J < pair.cost_J), key=lambda c: c.cost_J)  # fmt: skip
    if not nl:
        return ranking
    f = pair.params["structural_mode"]["freq_hz"]
    return _ahead(ranking, nl, lambda c: {"J_over_pair_J": c.cost_J / pair.cost_J, "over_pair_freq_hz": f})


def _gyro_path(records: Sequence[FlightRecord], channel: str, pairs, sample_rate_hz: float, w: np.ndarray,
               coherence_threshold: float) -> GyroPath:
    """:func:`jaxgwo._diagnose_where.gyro_path` on the identification records where every
    one logs the channel's attitude (:data:`jaxgwo._data.ATTITUDE_COLUMNS`), each signal
    taken relative to its trim as in :func:`_time_pairs`."""
    name = ATTITUDE_COLUMNS[channel]
    if not all(name in r.columns for r in records):
        return GyroPath(False, note=f"the identification records log no attitude {name!r}: the gyro path is not tested")
    att = [(u, _relative_to_trim(rec[name], rec.sample_rate)) for rec, (_t, u, _o, _y) in zip(records, pairs)]
    return gyro_path([(u, y) for _t, u, _o, y in pairs], att, sample_rate_hz, w, coherence_threshold=coherence_threshold)


def _gyro_filter_held(gyro: GyroPath, alpha: float) -> bool:
    """Whether the gyro path shows a filter that the ``sensor_lag`` candidate is fitted with:
    one at level ``alpha`` below the records' Nyquist frequency
    (:meth:`GyroPath.shows_filter`) and below the candidate box's top (100 Hz; one above it
    acts beyond the analysed band and is not held).  The one condition for holding the
    cutoff and for ranking the candidate first on the path's evidence
    (:func:`_gyro_path_order`)."""
    return gyro.shows_filter(alpha) and math.log(gyro.cutoff_hz) < _Z_HI[1]


def _gyro_path_order(ranking: Sequence[CandidateScore], gyro: GyroPath, alpha: float) -> tuple[CandidateScore, ...]:
    """``ranking`` (best first) as the gyro path decides it: where the attitude shows a gyro
    filter that the candidate holds (:func:`_gyro_filter_held`), a passing ``sensor_lag``
    goes first (``detail["ranked_by_gyro_path"]``); where it shows none (or one above the
    candidate's box) and rejects the candidate's cutoff, the ``sensor_lag`` no longer beats noise
    (``detail["refuted_by_gyro_path"]``, its score less 10, placed among the failing ones)
    and the passing ones keep their order.
    A flapping lag inside the rotor/fuselage loop moves rate and attitude alike, a gyro
    filter only the rate: this separates the two lags no cyclic input separates
    (:data:`SEPARATING_EXCITATION`).  Unchanged where the gyro path was not tested."""
    ranking = tuple(ranking)
    if not gyro.tested:
        return ranking
    i = next((j for j, c in enumerate(ranking) if c.effects == ("sensor_lag",)), None)
    if i is None:
        return ranking
    c = ranking[i]
    if _gyro_filter_held(gyro, alpha):
        if not c.beats_noise or i == 0:
            return ranking
        return _ahead(ranking, [c], lambda _c: {"ranked_by_gyro_path": 1.0})
    if c.beats_noise and gyro.refutes(c.params["sensor_lag"]["cutoff_hz"], alpha):
        return _demoted(ranking, [c], "refuted_by_gyro_path")
    return ranking


def _broad_pairs_refused(ranking: Sequence[CandidateScore]) -> tuple[CandidateScore, ...]:
    """``ranking`` (best first) with every ``structural_mode`` candidate whose pole damping
    exceeds :data:`_MODE_AGREEMENT_ZETA_P` no longer beating noise (``detail``'s
    ``broad_pair_no_resonance``, its score less 10, placed among the failing ones; the
    passing ones keep their order).  Such a pair describes no lightly damped resonance of
    the vocabulary (its draws reach pole damping 0.08) but a broad pole-zero pair, which
    bends the response as a lag does or stands for an airframe's extra pair: structure
    where the structure step takes it (:func:`_structure_route`), and no evidence for the
    effect otherwise, as :func:`_takes_time_domain_path` holds for such a refit.  Applied to
    the ranking the verdict is read from, after the structure step.

    On the stored diagnoses of fresh draws 539-557 (720 cases), every true resonance that
    beat noise (48) fitted pole damping 0.010-0.19, and 101 broad pairs beat noise, all on
    other effects (none on a ``none`` case): two were the verdict, paper flapping lags of
    33.5 and 18.0 ms called ``structural_mode`` at 6.6 Hz (pole damping 0.21) and 7.7 Hz
    (0.29) ahead of the lag (551/061, 555/045), now ``rotor_flapping`` and ``time_delay``
    with the lag second; the other 99 sat below the verdict."""
    ranking = tuple(ranking)
    broad = [c for c in ranking if c.beats_noise and c.effects == ("structural_mode",)
             and _broad_pair(c.params["structural_mode"])]
    return _demoted(ranking, broad, "broad_pair_no_resonance") if broad else ranking


_NEUTRAL_REL = 1e-6
"""How close to zero, relative to the largest magnitude of the vocabulary's range, an effect
parameter whose neutral value is zero counts as switched off
(:func:`_switched_off_refused`)."""


def _switched_off(c: CandidateScore) -> bool:
    """Whether ``c`` is one linear effect, scored on its ``J`` fit (not its time-domain
    refit), whose every parameter sits at its neutral value zero (within
    :data:`_NEUTRAL_REL` of the vocabulary's range): a delay of 0 s, a flapping lag of 0 s,
    a coupling gain of 0.  Effects whose neutral value is not zero (a gyro filter's
    infinite cutoff, a resonance's cancelled pair) are not judged here."""
    if len(c.effects) != 1 or c.detail.get("time_domain_path"):
        return False
    spec = EFFECTS[c.effects[0]]
    values = c.params.get(spec.name, {})
    if not spec.linear or any(v != 0.0 for v in spec.neutral) or set(values) != set(spec.params):
        return False
    return all(abs(float(values[q])) <= _NEUTRAL_REL * max(abs(lo), abs(hi))
               for q, (lo, hi) in zip(spec.params, spec.ranges))


def _switched_off_refused(ranking: Sequence[CandidateScore]) -> tuple[CandidateScore, ...]:
    """``ranking`` (best first) with every candidate that beats noise with its effect
    switched off (:func:`_switched_off`) no longer beating noise (``detail``'s
    ``effect_switched_off``, its score less 10, placed among the failing ones; the passing
    ones keep their order).  Such a candidate's model is its base's: the ``J`` it gains
    over the base is the base refitted, not the effect, so it is no evidence for the effect.

    Seen on R-50 resonances, where the refit on top of the structure finding lowers the
    base's ``J`` on its own: on the stored diagnoses of fresh draws 621-643 and development
    seeds 9101-9109, seven R-50 resonances had a flapping lag and a delay of exactly zero
    (1e-16 s or less) beat noise, each pair at one ``J`` (16.9 -> 6.8 on 627's case_048, 41.8
    -> 8.8 on 627's case_045); six ranked them below the resonance, and 627's case_048, whose
    resonance fit had its zero damping off the vocabulary's box (1.04), was called
    ``rotor_flapping`` on them.  No other candidate beat noise switched off there."""
    ranking = tuple(ranking)
    off = [c for c in ranking if c.beats_noise and _switched_off(c)]
    return _demoted(ranking, off, "effect_switched_off") if off else ranking


def _time_domain_refit(null, null_spec, val_predicted, val_measured, base_r2: float) -> TimeDomainRefit:
    """:class:`TimeDomainRefit` of the null refit ``null`` (a :class:`TimeFit`), whose model
    is ``null_spec`` and held-out prediction ``val_predicted``, against a base whose held-out
    R^2 is ``base_r2``."""
    _y, _p, r2, tic, gap = held_out_fit(val_measured, val_predicted, base_r2)
    k = np.asarray(null_spec.params, float) * np.array([null_spec.gain_scale, 1.0, 1.0, 1.0, 1.0])
    return TimeDomainRefit(
        params=dict(zip(("K", "tau", "M", "omega_s", "zeta_s"), map(float, k))),
        effects={e: {q: float(v) for q, v in ps.items()} for e, ps in null_spec.effects.items()},
        train_mse=float(null.train_mse), val_r2=r2, val_tic=tic, gap_closed=gap, predicted=tuple(val_predicted),
    )  # fmt: skip


@dataclass(frozen=True)
class _Base:
    """The model the candidates are added to and scored against: the nominal paper model,
    or the paper model with the extra mode of a structure finding (``linear`` then names
    it: every frequency-domain candidate is refitted jointly with it)."""

    spec: ModelSpec
    linear: tuple[str, ...]
    start: tuple
    """(objective, log paper parameters, effect coordinates or None, sign vector) the
    frequency-domain candidates are refitted from."""
    cost_J: float
    cost_J_sim: float
    """``J`` of the response estimated from the simulated identification output."""
    val_predicted: list
    val_r2: float


def _takes_time_domain_path(sc: CandidateScore, sc_td: CandidateScore | None, j_found: bool, alpha: float,
                            structure_zeta_z: float = math.inf, *, m_eff: float) -> bool:
    """Whether a linear candidate is scored by its time-domain refit (``sc_td``) instead of
    its ``J`` fit (``sc``).  Only a refit that passes on its own (output-error F-test,
    confirmed on VAL against the null refit; a resonance that ``J`` and the matched filter
    both find, :func:`_same_resonance`, need only not be contradicted there) may stand in,
    and only where ``J`` found no
    linear effect at all (``j_found`` false), or where ``J`` does find this one (F-test at
    ``alpha`` and BIC pass) but the ``J`` fit's paper parameters fail the held-out check:
    two independent tests then agree.  ``J`` weights the response's coherent points, the
    held-out records are time histories (seed-61 case_066, an 8.2 Hz mode at damping 0.07:
    the ``J`` fit lands on it, 8.25 Hz at ``J`` 36.4 -> 2.6, yet lowers the held-out R^2
    0.9955 -> 0.9951; refitted by output error it raises it to 0.9982, where a lag that
    fits ``J`` far worse, 23.6, had been the verdict).  A ``J`` fit that passes stands.

    A ``structural_mode`` refit whose zero damping exceeds ``structure_zeta_z`` (real
    zeros) or whose pole damping exceeds :data:`_MODE_AGREEMENT_ZETA_P` never stands in:
    it describes no lightly damped resonance of the vocabulary but a broad pole-zero pair,
    which is structure where ``J`` finds it (:func:`_structure_route`) and, found by output
    error alone, is no evidence for the effect.  Seed-89 case_064, a 24.7 Hz gyro filter
    that ``J`` fitted at 25.8 Hz: a refit's 4.9 Hz pair with zero damping 8.4 (zeros at
    0.29 and 81 Hz) bent the lag into a lead-lag and was the verdict; from the mode starts
    (:func:`_time_domain_mode_starts`) a pair at the box's corner, 45 Hz with pole damping
    0.99, imitated the lag.  The threshold is the mode-agreement signature's (set on seed
    41); on the stored rankings of development seeds 31, 41, 43, 61 and 89, every mode refit
    that stood in for a true mode fitted pole damping 0.026-0.073, those that stood in for
    another effect 0.44 and 0.99.

    Nor does a refit whose simulated response fits the measured one worse than the base's
    by more than chance (:func:`j_worse_p` below ``alpha`` on ``m_eff`` independent
    frequencies): a linear effect changes the response alike in both domains, and an
    output-error gain the measured response contradicts is the refit bending the servo
    and rotor term round something else, a gust or a nonlinearity.  On the stored rankings
    of fresh seeds 131-179 and development seed 113, every lag that stood in so was a wrong
    answer, and each one's ``J`` was 1.7-8.6 times the base's (reverse p 5e-5 to 1e-19:
    R-50 `none` case 179/041, R-50 backlash 151/040 and 163/039, R-50 resonance 113/019;
    second to fourth behind a true backlash on 163/067 and 173/015), while every refit
    that stood in for its true effect fitted ``J`` 0.03-1.28 times the base's (reverse p
    0.055 or more: the seven modes, one seed-113 gyro filter at 0.26).

    Nor does a refit that stopped where its box makes the effect vanish (:func:`_vanished`):
    its output-error gain over the null refit is then the servo's and rotor term's, not
    the effect's (seed-173 case_026, a rate limit called ``rotor_flapping`` with the lag
    at the box's 0.2 ms; seed-137 case_052, one called ``time_delay`` with no delay)."""
    if sc_td is None or not sc_td.beats_noise or sc.beats_noise:
        return False
    if any(_vanished(e, sc_td.params[e]) for e in sc_td.effects):
        return False
    if j_worse_p(sc_td, m_eff) < alpha:
        return False
    if sc_td.effects[-1:] == ("structural_mode",):
        mode = sc_td.params["structural_mode"]
        if mode["zeta_z"] > structure_zeta_z or mode["zeta_p"] > _MODE_AGREEMENT_ZETA_P:
            return False
    return not j_found or _j_finds(sc, alpha)


def _effect_size_passes(error_cut: float, min_error_ratio: float, corroborated: bool, delta_bic_val: float,
                        acts_on_held_out: bool, held_out_bic: float) -> bool:
    """Whether a nonlinear candidate's output-error F-test counts as evidence: it is backed by
    an effect size.  Gusts dominate the identification output error, so a mild clipping fits
    gust-induced error significantly; the F-test counts only where the candidate cuts the
    null refit's error by ``min_error_ratio`` (``error_cut``, null over candidate), where the
    amplitude test of step 2 independently shows the change with amplitude this effect
    predicts (``corroborated``), or where the held-out records show the effect's size: their
    BIC improves over the null refit by ``held_out_bic`` (``delta_bic_val`` < -``held_out_bic``).
    Sweeps reach a rate limit
    seldom, held-out multisteps often: seed-61 case_071, a rate limit of 11.3 fitted at 11.9,
    cuts the identification error by x1.039 (p 7e-50) and the held-out squared error by
    x2.9 (BIC -442).  On the stored rankings of development seeds 31, 41, 43 and 61
    (99 cases), every other nonlinear refit that passed the F-test at alpha with a cut
    below x1.05 (26, one a true rate limit the held-out records do not show: case_045)
    raised the held-out BIC (+3 to +106), so none of them passes.

    The held-out BIC shows the effect's size only where the nonlinearity acts on those
    records (``acts_on_held_out``, :func:`jaxgwo._diagnose_which.nonlinearity_acts`);
    where it does not, their gain is the refitted servo's and rotor's alone, which a
    clipping of gust-induced error on the identification records can buy as well.  Fresh
    seed 577's case_022, a paper plant without an effect, was called ``saturation`` so:
    a limit of 0.285 fitted to the peaks of the larger sweep (cut x1.028, p 4e-5, the
    amplitude test silent), above the held-out input's largest 0.204, with held-out BIC
    -11.0 (z 2.94): now ``none``.  Of the 1869 nonlinear candidates stored for draws
    565-577, eleven beat noise on the held-out BIC alone; rediagnosed, five do not act on
    those records (that saturation, and four rate limits of 6.8-10 rad/s on the paper model
    of R-50 delays, ranked below the delay, 565/055, 569/044, 569/065, 573/071) and no
    longer beat noise, and the six that act stand (rate limits 565/068 and 569/049,
    backlashes 573/031, 575/029 and 577/025, the saturation of 573/058); no other verdict
    moved.  Set there, in sample.

    How much the held-out BIC must improve (``held_out_bic``, 2): a difference of 2 is where
    Kass and Raftery (1995) put the edge of "positive" evidence (a Bayes factor of about e);
    below it, "not worth more than a bare mention".  It had been any improvement.  Fresh seed
    607's case_022, a paper plant without an effect, was called ``saturation`` at a limit of
    0.152 on a held-out BIC of -1.4 (cut x1.022, output-error p 1e-4, the amplitude test
    silent, the limit acting on the held-out records).  On the stored details of draws
    593-607 (576 cases) it is the only candidate beating noise whose size rested on a
    held-out BIC between -2 and 0; every other candidate that beat noise with a cut under
    x1.05 and the amplitude test silent improved it by 3.1 or more or did not need it
    (``J`` against the null refit).  Any level from 1.5 to 3 reads those draws alike; 2
    is the convention, not a fit.  Set there, in sample (``/work/runs/s80/bicalone.py``)."""
    return corroborated or error_cut >= min_error_ratio or (delta_bic_val < -held_out_bic and acts_on_held_out)


def _amplitude_backed(corroborated: bool, p_output_error: float, alpha: float) -> bool:
    """Whether a nonlinear candidate stands on two independent tests of the identification
    records, so that the held-out records need only not contradict it (``z_min`` and a
    positive gap, as a linear ``J`` fit) instead of confirming it (``z_min_time``): the
    amplitude test of step 2 shows the change with amplitude this nonlinearity predicts
    (``corroborated``, :func:`_amplitude_agreement`), and its output-error F-test passes at
    ``alpha`` itself, not only at the ``alpha_amplitude`` that backing otherwise grants.

    The held-out 3-2-1-1s and doublets reach a rate limit seldom, and on an R-50 the null
    refit beside them carries the pole pair's model-form error, so a real limit's held-out
    z can be negative: seed-505 case_004 (R-50, rate 3.96, fitted 5.63 at output-error p
    3e-15, the amplitude test agreeing) z -1.11 with gap 0.26; 501/009 (R-50, 3.55: p 2e-5,
    z -1.24, gap 0.05); 501/032 (paper, p 4e-29, z 0.91, gap 0.06); each answered ``none``.
    Over the 288 cases of draws 499-505 the amplitude test flagged no ``none`` case and
    3 of the 160 linear-effect cases; on those three no nonlinear candidate that agreed with
    it passed its F-test below p 0.07.  Set on those four stored draws (in sample); on the
    96 ``none`` and nonlinear cases of development seeds 9011-9015 it moved no verdict (the
    amplitude test flagged none of their 24 ``none`` cases)."""
    return bool(corroborated and p_output_error < alpha)


def _amplitude_sizes(corroborated: bool, by_amplitude: bool, z_val: float, z_min_time: float) -> bool:
    """Whether the amplitude test's agreement (``corroborated``) may count as a nonlinear
    candidate's effect size (:func:`_effect_size_passes`, :func:`_pair_free_effect_size`):
    not where it already stands in for the held-out records' confirmation, that is where
    the candidate passed on its backing (:func:`_amplitude_backed`, ``by_amplitude``) and
    the held-out z (``z_val``) is at most ``z_min_time``.  One test counts once: the
    amplitude test shows that the response changes with amplitude, not that this fit
    explains much of it, so such a candidate needs a cut of the null refit's error as its
    size.

    Fresh seed 589's case_045, an R-50 without an effect, was called ``backlash`` so:
    width 0.0019, pair refitted, cut x1.013 (p 5e-4), held-out z -0.07, the amplitude test
    agreeing.  In the stored diagnoses of draws 565-589 (936 cases) five candidates of the
    final rankings passed on that backing: 565/053's rate limit, the verdict and right, on
    a x1.144 cut, which stands; and four on cuts of x1.013-1.046, all wrong: that false
    alarm, 575/019's R-50 rate limit called ``backlash`` (x1.017) and two second-ranked
    nonlinearities beside a right one (567/067, 577/067).  Set there, in sample."""
    return bool(corroborated and not (by_amplitude and not z_val > z_min_time))


def _pair_free_effect_size(error_cut: float, pair_free_error_ratio: float, corroborated: bool, j: float,
                           j_null: float) -> bool:
    """:func:`_effect_size_passes` for a nonlinear candidate on a structure finding whose
    pole pair it refitted beside it (:class:`DiagnoseSettings`: ``pair_free_error_ratio``):
    the amplitude test's backing or a cut of the (pair-free) null refit's error by
    ``pair_free_error_ratio``, and in either case a ``J`` (``j``) no worse than that null
    refit's (``j_null``).  Neither ``min_error_ratio``, the held-out BIC nor ``J`` against
    the null refit counts as an effect size: once the pair is free the airframe's
    model-form error passes them (R-50 ``none`` cases 313/028, 331/068 and 331/069 on
    x1.05-1.06 cuts or the BIC; fresh seed 367's case_039 on ``J`` at 0.38 of the null's).
    But a ``J`` above the null's contradicts the candidate: the nonlinearity then buys its
    cut of the output error with a worse fit of the coherent response, which a servo
    nonlinearity the records carry does not (the pair-free null, fitted to time histories
    the nonlinearity distorts, fits ``J`` worst).  On the rediagnosed R-50 rate limits of
    draws 313-379 found this way, ``J`` was 0.19-0.58 of the null's (313/011, 317/021,
    317/064, 373/050, 379/052); the two wrong names of the path had 1.54 and 1.27
    (313/047, a rate limit called ``saturation``, the amplitude test agreeing; fresh seed
    379's case_071, a 13.9 Hz resonance called ``saturation`` on a x1.082 cut).  Set there,
    in sample."""
    return bool((corroborated or error_cut >= pair_free_error_ratio) and j <= j_null)


def _refitted_pair_p(held_mse: float, free_mse: float, n_eff: float) -> float:
    """p of the F-test that a structure finding's pole pair, refitted beside a nonlinearity
    (three parameters), cuts the identification output error of the fit with the pair held
    from ``held_mse`` to ``free_mse``, on ``n_eff`` effective samples (those of the null
    refit's residuals) less the fit's eight parameters.

    Where a nonlinearity beats noise both with the pair held and refitted, :func:`diagnose`
    gives it as its pair-refitted fit where this p is below ``alpha``.  The pair was fitted
    to ``J`` before any nonlinearity and has absorbed part of its describing function
    (:func:`jaxgwo._diagnose_which._refit_pair_beside`), so the held fit predicts less
    than the records support.  R-50 rate limits re-simulated from their seeds: 557/053,
    error 2.14e-4 -> 1.61e-4, held-out R^2 0.9605 -> 0.9819 (true model 0.9891); 517/059,
    0.9612 -> 0.9821 (0.9992); 509/039, 0.9454 -> 0.9702 (0.9976); backlash 545/018,
    0.9757 -> 0.9791 (0.9972).  Set there, in sample."""
    return f_test_p(held_mse, free_mse, 3, n_eff - 8)


def _pair_refit_stands(held_beats: bool, refit_beats: bool, p_pair: float, alpha: float) -> bool:
    """Whether a nonlinear candidate on a structure finding is scored as its fit with the
    finding's pole pair refitted beside it rather than held: where that fit beats noise
    (against a null refit given the same freedom, :func:`_pair_free_effect_size`) and
    either the pair-held fit does not, or the refitted pair cuts the held fit's
    identification error at ``alpha`` (``p_pair``, :func:`_refitted_pair_p`)."""
    return refit_beats and (not held_beats or p_pair < alpha)


def _against_null_j(p_mse: float, p_j_null: float, j: float, j_null: float, alpha: float,
                    j_null_ratio: float) -> tuple[bool, float]:
    """A nonlinear candidate's identification evidence from its output-error F-test
    (``p_mse``) and from its ``J`` against the null refit's (``p_j_null``, ``j`` against
    ``j_null``): whether the ``J`` test passes as evidence and effect size both (F-test at
    ``alpha`` and ``j`` at most ``j_null_ratio`` of ``j_null``; the held-out records then
    need only not contradict it), and the candidate's identification p, the smaller of the
    two where ``j`` has that effect size, else the output error's alone
    (:class:`DiagnoseSettings`: ``j_null_ratio``)."""
    sized = j <= j_null_ratio * j_null
    return bool(sized and p_j_null < alpha), (min(p_mse, p_j_null) if sized else p_mse)


_WHY_OUTPUT_ERROR = {
    "structural_mode": "the response is measured over windows of a few seconds, which widen a lightly damped peak",
    "sensor_lag": "a gyro filter acts mostly above the analysed band, where that fit sees only its phase lag",
    "time_delay": "that fit can trade the delay against the servo, and the refit predicts the held-out records better",
    "rotor_flapping": "that fit can trade the lag against the servo, and the refit predicts the held-out records better",
}
"""The summary's reason why :func:`_output_error_estimate` reports an effect's refit."""

_LAG_REFIT_R2 = 0.001
"""How much better (held-out R^2) a ``time_delay``'s or ``rotor_flapping``'s output-error
refit must predict the held-out records than its ``J`` fit for the refit to be reported
(:func:`_output_error_estimate`)."""


def _output_error_estimate(sc: CandidateScore, refit: tuple | None) -> CandidateScore:
    """A candidate with a ``sensor_lag``, scored on ``J``, with its model replaced by its
    time-domain refit (``refit``: that refit's score and model), where the refit keeps the
    effect (a gyro filter whose cutoff the gyro path measured: its refit with the cutoff
    held, :func:`_gyro_filter_model`); so is a ``time_delay`` or a ``rotor_flapping``
    whose refit beats noise and predicts the held-out records better than its ``J`` fit by
    :data:`_LAG_REFIT_R2` or more, and a ``structural_mode`` whose refit is a lightly
    damped resonance (below).

    ``J`` decides (the evidence fields and the score stay the ``J`` fit's: ``cost_J``,
    ``delta_bic``, ``train_p``, ``z_score``, ``delta_bic_val``, ``beats_noise``,
    ``score``); the output-error refit estimates (``params``, ``sigma``, ``val_r2``,
    ``val_tic``, ``gap_closed``, the held-out prediction).  ``J`` sees the response up to
    the analysed band's top (``w_max``, 19 Hz by default), while a gyro filter of 5-40 Hz
    acts mostly above it: ``J`` sees only its phase lag, which the refitted servo shares.
    The refit (servo and rotor term with the effect, Gauss-Newton from the ``J`` fit and
    from the null refit, :func:`refit_linear_time_domain`) fits the time histories up to
    Nyquist.  The band is not the whole reason (seed-61 case_008: a sweep to 15.4 Hz, and
    ``J`` read 25.0 Hz for 36.4, the refit 36.1); the choice rests on what was measured.
    On the paper-plant gyro filters of development seeds 61 and 89 it moved the
    cutoff closer to the truth in 10 of 11 (median error 25 -> 7 %, within 15 % in 4 -> 8)
    and raised the held-out R^2 of 29 of the 30 ``sensor_lag`` candidates that beat noise
    there.  A flapping lag and a delay lie inside the band, and there the refit was no
    better: it moved the ``tau_f`` of seed 89's paper flapping lags further off (median
    12 -> 18 %) and one delay from 0.3 to 4.5 ms off.  A delay's ``J`` fit can trade the
    delay against the refitted servo, though, and the held-out records tell which of the
    two models is right: fresh seed 227's case_035 (18.2 ms) read 23.9 ms on ``J`` and
    18.2 ms refitted, held-out R^2 0.9936 against 0.9970.  Over the 24 paper-plant delays
    of fresh seeds 199, 211, 223 and 227 the refit is reported on 12 (where it predicts
    those records better by 0.001 or more); the largest error falls from 5.6 to 2.2 ms,
    and every delay is then within 3 ms (23 of 24 on ``J`` alone); on four of the 12 the
    refit is the further off (0.3 -> 0.4, 0.9 -> 2.2, 0.8 -> 1.3, 1.2 -> 2.2 ms).
    So can a flapping lag's: fresh seed 453's case_029 (36.9 ms), named on ``J`` at 24.4 ms,
    predicted the held-out records at R^2 0.9661 where the true model reaches 0.9995 (the
    study's 0.02 target missed), its refit (32.7 ms) at 0.9995.  Of the 11 paper flapping
    lags of development seeds 453, 9001 and 9003 rediagnosed with the rule (session 68) it
    took the refit on that one only; on the other ten the two predict within 0.001.
    Only against the paper model: on
    top of a structure finding the refit holds the mode where ``J`` put it (R-50 delays
    refitted there read 70-100 % low on the stored rankings of development seeds 41 and
    43).

    So is a ``structural_mode`` whose refit is a resonance of the vocabulary's shape
    (:func:`_resonance_in_box`).  The response is estimated over windows of a few seconds
    (the composite's), whose spectral window widens a lightly damped peak, and ``J`` reads
    that widened peak's damping; the time histories have no window.  On the stored
    diagnoses of fresh draws 373-473 (``/work/runs/s66/modeoe.py``) the ``J`` fits of the 97
    paper-plant resonances named on ``J`` read the pole damping high, median 1.27 times
    the truth (10-90 %: 1.02-1.78), the zero damping 1.20 times and the frequency 1.005
    times, the latter several times the quoted 1-sigma.  On the 92 whose refit is such a
    resonance the refit read 1.006, 1.015 and 1.0001 (median ``|log|`` error of the pole
    damping 0.263 -> 0.045, of the frequency 0.0068 -> 0.0020; the refit the nearer on 75
    and 73 of the 92) and predicted the held-out records better (R^2 +0.0006, median).  84
    of them lay within the ``J`` fit's half-power half-width; of the eight that lay
    elsewhere the refit was the nearer on seven (seed-421 case_014, 18.36 Hz: ``J`` 13.54,
    refit 17.77; the exception seed-455 case_061, 12.47 Hz: 11.92 and 13.08).  The five
    wrong ``structural_mode`` verdicts there keep their verdicts: four paper rate limits
    whose refit is no resonance, and a ``none`` case.

    Not where the refit stops where its search box makes an effect vanish (a cutoff
    of 100 Hz, :func:`_vanished`): the ``J`` fit's then stands.  The ``J`` fit's parameters
    stay in ``detail`` as ``j_<param>``.  The top two combined, when both are linear and
    one is a ``sensor_lag``, are estimated alike (their pair refitted from its ``J``
    fit)."""
    if refit is None or sc.detail.get("time_domain_path"):
        return sc
    sc_td, _spec = refit
    lag = sc.effects in (("time_delay",), ("rotor_flapping",)) and sc_td.beats_noise \
        and sc_td.val_r2 >= sc.val_r2 + _LAG_REFIT_R2
    mode = sc.effects == ("structural_mode",) and _resonance_in_box(sc_td.params["structural_mode"])
    if not ("sensor_lag" in sc.effects or lag or mode) or any(_vanished(e, sc_td.params[e]) for e in sc.effects):
        return sc
    det = dict(sc.detail) | {f"j_{p}": v for e in sc.effects for p, v in sc.params[e].items()}
    det["estimate_output_error"] = 1.0
    return dataclasses.replace(sc, params=sc_td.params, sigma=sc_td.sigma, val_r2=sc_td.val_r2,
                               val_tic=sc_td.val_tic, gap_closed=sc_td.gap_closed, predicted=sc_td.predicted,
                               detail=det)  # fmt: skip


_TWO_READINGS = {"rotor_flapping": "tau_f"}
"""The effects whose 1-sigma on the paper model counts the spread of their two readings
(:func:`_two_readings_bound`), with the parameter each reads; a delay's two readings are
combined instead (:func:`_delay_from_two_readings`)."""


def _two_readings_bound(sc: CandidateScore, refit: tuple | None) -> CandidateScore:
    """A ``rotor_flapping`` on the paper model read both by its ``J`` fit and by its
    output-error refit (``refit``, as for :func:`_output_error_estimate`): its 1-sigma with
    half the two readings' difference added in quadrature, recorded in ``detail`` as
    ``two_readings_half_spread``.  The estimate stays as it was.

    The two fits weight the data differently (``J`` the response's coherent points, the
    output error the time histories) and each trades a lag against the refitted servo in
    its own way, so their readings differ by more than either one's random error allows.
    Two readings of one quantity give half their difference as the standard uncertainty
    of their mean (a Type A evaluation from two observations, GUM 4.2), a term the
    single-fit covariance lacks.  On the stored diagnoses of fresh draws 373-485 the quoted
    1-sigma of the 167 paper-plant flapping lags named there held the truth on 57 %
    (81 % within 2-sigma); with that term, 62 % and 90 % (``/work/runs/s67/dsig4.py``, in
    sample; on the 222 delays 57 -> 69 % and 85 -> 96 %, where
    :func:`_delay_from_two_readings` now does better).  Not where the refit stopped where
    the effect vanishes (:func:`_vanished`), nor on the time-domain path (the refit is then
    the only reading), nor beside a structure finding."""
    if refit is None or sc.detail.get("time_domain_path") or len(sc.effects) != 1 \
            or sc.effects[0] not in _TWO_READINGS:
        return sc
    (e,) = sc.effects
    p = _TWO_READINGS[e]
    sc_td, _spec = refit
    if _vanished(e, sc_td.params[e]):
        return sc
    other = sc.detail[f"j_{p}"] if sc.detail.get("estimate_output_error") else sc_td.params[e][p]
    half = 0.5 * abs(sc.params[e][p] - other)
    sigma = dict(sc.sigma) | {e: dict(sc.sigma[e]) | {p: math.hypot(sc.sigma[e][p], half)}}
    return dataclasses.replace(sc, sigma=sigma, detail=dict(sc.detail) | {"two_readings_half_spread": half})


def _delay_from_two_readings(j_fit: CandidateScore, sc: CandidateScore, refit: tuple | None) -> CandidateScore:
    """A ``time_delay`` on the paper model read by its ``J`` fit (``j_fit``, the candidate as
    ``J`` scored it) and by its output-error refit (``refit``): ``sc``, the estimate
    :func:`_output_error_estimate` made of it, with its delay the inverse-variance mean of
    the two readings and its 1-sigma that mean's, multiplied by the readings' scale factor
    :math:`S = |d_J - d_T| / \\sqrt{\\sigma_J^2 + \\sigma_T^2}` where that exceeds 1 (the
    Particle Data Group's rule for averaging measurements that disagree beyond their
    errors).  ``detail`` keeps both readings (``j_delay_s``, ``td_delay_s``), their bounds
    (``j_sigma_delay_s``, ``td_sigma_delay_s``) and ``delay_scale_factor``; the model and
    its held-out scores stay those ``sc`` reports (``J`` decides, the refit's where it
    predicts the held-out records better by :data:`_LAG_REFIT_R2`).

    The two fits weight the data differently and trade the delay against the refitted
    servo each in its own way: over the 222 paper-plant delays named in fresh draws
    373-485 their errors were uncorrelated (r 0.06), and neither reading nor the choice
    between them by the held-out records was within 3 ms on every one.  Rediagnosed with
    both bounds printed (``/work/runs/s67/sigprobe.py``; ``sigeval.py`` compares the
    estimators), on every other paper delay of draws 443-485 taken in case order (69
    cases) the reported reading was more than 3 ms off on 5 (rms 1.59 ms, largest 6.63),
    the inverse-variance mean on none (rms 0.88 ms, largest 2.29; their plain mean 4, the
    reading of smaller bound 3), and its scaled bound held the truth within 1-sigma on
    67 % and within 2-sigma on 93 % (:func:`_two_readings_bound`'s widening of the
    reported reading: 70 % and 96 %, at a median width 1.6 times this one's).  Chosen
    after five cases picked for their large errors had been looked at, on these cases: no
    parameter was set.  Seed 491's case_029, the 34.1 ms delay that ``J`` read 52.7 ms
    +-75.6 and the refit 29.5 ms +-4.1, is then 29.6 ms.  Not where
    the refit stopped where the delay vanishes (:func:`_vanished`), where either bound
    is not a positive number, nor on the time-domain path (the refit is then the only
    reading), nor beside a structure finding (:func:`_airframe_bracket`)."""
    if refit is None or j_fit.effects != ("time_delay",) or j_fit.detail.get("time_domain_path"):
        return sc
    sc_td, _spec = refit
    if _vanished("time_delay", sc_td.params["time_delay"]):
        return sc
    d_j, s_j = j_fit.params["time_delay"]["delay_s"], j_fit.sigma["time_delay"]["delay_s"]
    d_t, s_t = sc_td.params["time_delay"]["delay_s"], sc_td.sigma["time_delay"]["delay_s"]
    if not all(math.isfinite(v) and v > 0.0 for v in (s_j, s_t)):
        return sc
    w_j, w_t = s_j**-2, s_t**-2
    mean = (w_j * d_j + w_t * d_t) / (w_j + w_t)
    scale = max(1.0, abs(d_j - d_t) / math.hypot(s_j, s_t))
    det = dict(sc.detail) | {"j_delay_s": d_j, "td_delay_s": d_t, "j_sigma_delay_s": s_j, "td_sigma_delay_s": s_t,
                             "delay_scale_factor": scale, "delay_inverse_variance_mean": 1.0}  # fmt: skip
    return dataclasses.replace(sc, params=dict(sc.params) | {"time_delay": {"delay_s": mean}},
                               sigma=dict(sc.sigma) | {"time_delay": {"delay_s": scale / math.sqrt(w_j + w_t)}},
                               detail=det)  # fmt: skip


def _paper_estimate(sc: CandidateScore, refit: tuple | None) -> CandidateScore:
    """A candidate on the paper model as the report estimates it from its ``J`` fit ``sc``
    and its output-error refit ``refit``: :func:`_output_error_estimate`, then a delay's two
    readings combined (:func:`_delay_from_two_readings`) or a flapping lag's bound widened
    by them (:func:`_two_readings_bound`)."""
    est = _output_error_estimate(sc, refit)
    return _two_readings_bound(_delay_from_two_readings(sc, est, refit), refit)


_FLAP_PAIR_READS_S = 1e-3
"""The least flapping lag the pair fit must read for :func:`_flapping_between_airframes`,
set in sample: on the R-50 ``none`` cases of development seed 9101 the pair fit read 0-0.2 ms
(0 the ``J`` box's floor, 0.2 ms that of the time-domain box,
:data:`jaxgwo._diagnose_which._FLAP_LO_TIME_DOMAIN_S`); on the R-50 flapping lags it answered
``none`` 1.3-7.3 ms."""
_FLAP_RANGE_S = EFFECTS["rotor_flapping"].ranges[0]
"""The vocabulary's flapping lags (10-60 ms): the lead-lag airframe's reading must lie among them."""
_FLAP_LEAD_LAG_READS_S = 13e-3
"""The least lag the lead-lag airframe must read for :func:`_flapping_between_airframes`
(within :data:`_FLAP_RANGE_S`).  Set in session 86, in sample, on fresh seed 639's case_004, an
R-50 ``none`` named at 10.6 +- 3.1 ms (3.4 sigma, so :data:`_FLAP_NAMED_Z` let it through):
over the stored diagnoses of fresh seeds 621-641 and development seeds 9101-9109, the 46 R-50
flapping lags (truths 10.0-32.1 ms) with a lead-lag reading read 15.4 ms or more, but for
one read below the vocabulary (629's case_013, 9.2 ms for 12.3); the four other cases read in
10-13 ms were the two R-50 ``none`` the rule named (10.6 and 633's case_041, 11.5 ms), an R-50
resonance (10.9) and a gyro filter (10.0).  The lead-lag reads a short lag long (10.0-11.1 ms
at 15.4-24.4), so a reading at the vocabulary's floor is more likely the airframe's misfit
than a lag.  Its cost: of the seven lags of development seed 9101 the rule was set on
(session 83's probe, not stored) one read 11.8 ms and would no longer be named."""
_FLAP_NAMED_Z = 2.0
"""How many of its own quoted 1-sigma (the bracket's) the lag :func:`_flapping_between_airframes`
names must lie above zero.  Set in session 85 on fresh seed 633's case_041, an R-50 ``none``
named an 11.5 +- 6.9 ms lag (1.7 sigma; the pair fit's own reading 6.8 +- 6.8 ms): the twenty-one
lags named before (development seeds 9105 and 9107, fresh seeds 621-633, one of them 625's
resonance) stood 3.1-4.1 of their sigma above zero."""


def _flapping_between_airframes(ranking: Sequence[CandidateScore], fits: Mapping,
                                lin_from: Mapping) -> tuple[CandidateScore, ...]:
    """``ranking`` (best first, on top of a structure finding) with, where nothing beats
    noise, a ``rotor_flapping`` that both airframe models read as a lag named: the pair
    fit's reading at least :data:`_FLAP_PAIR_READS_S`, off its floor, and the
    :class:`jaxgwo._diagnose_which.LeadLagAirframe` refit's
    (:func:`jaxgwo._diagnose_which.airframe_lag_refit`) among the vocabulary's lags,
    :data:`_FLAP_RANGE_S`, and at least :data:`_FLAP_LEAD_LAG_READS_S`, with ``J`` below the
    pair fit's, and that reading at least
    :data:`_FLAP_NAMED_Z` of the two readings' bracket's 1-sigma above zero (not where that
    1-sigma is unknown).  The candidate then beats
    noise at the head, its lag the lead-lag's reading with that
    1-sigma (:func:`_airframe_bracket`, then :func:`_lead_lag_reading`; ``detail``:
    ``tau_f_pair_s``, ``tau_f_airframe_s``, ``airframe_J_ratio`` and
    ``named_between_airframes``); otherwise ``ranking`` is unchanged.

    Why: beside the R-50's flybar pair a flapping lag is absorbed by the pair, which reads
    it at 0.1-0.7 of the truth, and on the held-out multisteps it seldom beats noise
    (R-50 flapping lags found 69 of 269 in 141 fresh draws).  The two airframe models err
    on opposite sides of the truth (:func:`jaxgwo._diagnose_which.airframe_lag_refit`), so
    a lag both read is one the airframe's misfit alone does not make.  Set on development
    seed 9101 (R-50 plants only, 12 cases each of ``none`` and ``rotor_flapping``; records
    in docs/diagnosis-record.md, session 83): the seven flapping lags answered ``none`` read
    1.3-7.3 ms on the pair and 11.8-28.6 ms on the lead-lag; the twelve ``none`` cases
    read at most 0.2 ms on the pair (the lead-lag, on the ten answered ``none``, up to
    10.2 ms: neither reading alone separates them).  Out of sample, the pair read at most
    0.33 ms on the fourteen ``none`` cases of development seed 9103.  The evidence is the
    identification records': the summary says the held-out records do not show it beyond
    noise.  The lead-lag's reading is held to the vocabulary's top as well as its floor
    since session 84, as the summary had said: fresh seed 625's case_071, an R-50
    resonance (11.3 Hz), read 2.2 ms on the pair and 63.1 ms on the lead-lag and was
    named a flapping lag; the seventeen lags named before read at most 37.2 ms.  A lag
    named must stand out from its own bound since session 85 (:data:`_FLAP_NAMED_Z`): fresh
    seed 633's case_041, an R-50 ``none``, read 6.8 ms on the pair, whose fit left it
    +-6.8 ms, and 11.5 ms on the lead-lag, and was named.  The lead-lag must read 13 ms
    or more since session 86 (:data:`_FLAP_LEAD_LAG_READS_S`): fresh seed 639's case_004,
    an R-50 ``none``, read 1.2 ms on the pair and 10.6 +- 3.1 ms on the lead-lag, and was
    named."""
    ranking = tuple(ranking)
    pair = ("structural_mode", "rotor_flapping")
    if not ranking or ranking[0].beats_noise or pair not in fits:
        return ranking
    sc = next((c for c in ranking if c.effects == ("rotor_flapping",)), None)
    if sc is None or not sc.params["rotor_flapping"]["tau_f"] >= _FLAP_PAIR_READS_S:
        return ranking
    refit = airframe_lag_refit(lin_from[pair][0], fits[pair].x, "rotor_flapping")
    lo, hi = _FLAP_RANGE_S
    if refit is None or not (max(lo, _FLAP_LEAD_LAG_READS_S) <= refit[0] <= hi and refit[1] < fits[pair].cost_J):
        return ranking
    named = _lead_lag_reading(_airframe_bracket(dataclasses.replace(sc, beats_noise=True), fits, lin_from, refit))
    if not named.params["rotor_flapping"]["tau_f"] >= _FLAP_NAMED_Z * named.sigma["rotor_flapping"]["tau_f"]:
        return ranking
    return (named, *(c for c in ranking if c is not sc))


def _lead_lag_reading(named: CandidateScore) -> CandidateScore:
    """A flapping lag :func:`_flapping_between_airframes` named, its lag reported as the
    lead-lag airframe's reading (``detail``'s ``tau_f_airframe_s``) rather than the
    bracket's centre, with the bracket's 1-sigma kept (``named_between_airframes`` set).

    Why: where a flapping lag that beats noise sits beside the R-50's flybar pair, the pair
    reads it at 0.31-0.68 of the truth and the lead-lag long, so the centre is the reading
    (:func:`_airframe_bracket`).  Where this rule names one, the pair has taken almost all
    of it (1.2-4.8 ms for truths of 13.6-30.2 ms) and the centre is little more than half
    the lead-lag's reading: on the ten rule-named lags of session 83 (development seed 9105's
    five, fresh seed 621's case_038 and 623's four; docs/diagnosis-record.md, session 84)
    the centre erred -2.2 to -16.1 ms (all low, 6 of 10 within its 1-sigma, 8 within
    2-sigma), the lead-lag -6.4 to +8.6 ms (mean +1.6; 6 within the same 1-sigma, 10 within
    2-sigma; root-mean-square error 5.3 ms against the centre's 8.4).  Set on those ten;
    the 1-sigma is the bracket's, which counts the two models' spread."""
    lag = {"tau_f": named.detail["tau_f_airframe_s"]}
    return dataclasses.replace(named, params={**named.params, "rotor_flapping": lag},
                               detail={**named.detail, "named_between_airframes": 1.0})  # fmt: skip


def _airframe_bracket(sc: CandidateScore, fits: Mapping, lin_from: Mapping,
                      refit: tuple[float, float] | None = None) -> CandidateScore:
    """A ``time_delay`` or ``rotor_flapping`` that beats noise on top of a structure finding,
    its lag read as the centre of the pair fit's and a
    :class:`jaxgwo._diagnose_which.LeadLagAirframe` refit's
    (:func:`jaxgwo._diagnose_which.bracketed_lag`; both kept in ``detail`` as
    ``delay_pair_s`` and ``delay_airframe_s``, or ``tau_f_pair_s`` and ``tau_f_airframe_s``),
    where that refit fits ``J`` better than the pair (``detail``'s ``airframe_J_ratio``
    below 1): there the pair is the poorer description of the airframe, and the two read
    the lag from opposite sides (every R-50 delay of the blind study, J ratio 0.54-0.83).
    Where the pair describes it better, as a pole pair with real zeros on the paper model
    does (in ``test_structure_hidden_behind_a_long_delay_is_found`` the lead-lag family
    read its 60 ms delay 14.5 ms long, the centre 7 ms), only the ratio is recorded.  Only
    the reported lag and its bound change: the model scored on the held-out records, and
    so the ranking, stays the pair fit's.  Any other candidate, or one without that fit,
    is returned as it is, and so is one whose lead-lag reading is in ``detail`` already;
    ``refit``, where given, is that refit made already (:func:`_flapping_between_airframes`)."""
    if len(sc.effects) != 1 or sc.effects[0] not in AIRFRAME_LAGS or not sc.beats_noise:
        return sc
    (e,) = sc.effects
    param, _i, stem = AIRFRAME_LAGS[e]
    pair = ("structural_mode", e)
    if pair not in fits:
        return sc
    if f"{stem}_airframe_s" in sc.detail:  # read already (_flapping_between_airframes)
        return sc
    refit = refit if refit is not None else airframe_lag_refit(lin_from[pair][0], fits[pair].x, e)
    if refit is None:
        return sc
    ratio = refit[1] / fits[pair].cost_J if fits[pair].cost_J > 0.0 else math.inf
    if not ratio < 1.0:
        return dataclasses.replace(sc, detail={**sc.detail, "airframe_J_ratio": ratio})
    v_pair = sc.params[e][param]
    v, s = bracketed_lag(v_pair, sc.sigma.get(e, {}).get(param, math.nan), refit[0])
    return dataclasses.replace(sc, params={**sc.params, e: {param: v}}, sigma={**sc.sigma, e: {param: s}},
                               detail={**sc.detail, f"{stem}_pair_s": v_pair, f"{stem}_airframe_s": refit[0],
                                       "airframe_J_ratio": ratio})  # fmt: skip


def _output_error_start(z: np.ndarray, x: np.ndarray) -> np.ndarray:
    """A start of :func:`refit_linear_time_domain` (its ``LinearOutputError`` coordinates:
    the six effect coordinates ``z``, then log servo frequency and damping, log ``tau`` and
    ``M``) from a frequency-domain fit's ``x`` (log ``K``, ``tau``, ``M``, servo frequency
    and damping, then its effect coordinates)."""
    return np.r_[z, x[3], x[4], x[1], x[2]]


def _gyro_filter_model(base: ModelSpec, train, x: np.ndarray) -> TimeFit | None:
    """The model of a gyro filter whose cutoff the gyro path measured: the paper model with
    the filter, its servo and rotor term refitted by output error to the identification
    records ``train`` from its ``J`` fit ``x`` (the cutoff held there) with the cutoff held
    (:func:`refit_linear_time_domain`); ``None`` where that refit fails.

    The cutoff is the gyro against the attitude, independent of the plant model, and
    nothing here moves it; but ``J`` reads the paper parameters from the response's
    coherent points, which can leave the servo or the rotor term's slow part loosely
    measured, and the held-out records are time histories.  On the nine paper gyro filters
    of development seeds 9001 and 9003 (session 68) the ``J`` fit's held-out R^2 fell up
    to 0.0144 short of the true model's (seed 9003's case_006: 0.9853 against 0.9997); this
    refit's fell at most 0.0001 short on all nine and predicted none worse than the ``J``
    fit (0.9853 -> 0.9997 there)."""
    return refit_linear_time_domain(base, train, ("sensor_lag",), [_output_error_start(x[5:], x)],
                                    held=("sensor_lag",))  # fmt: skip


_TD_MODE_STARTS = tuple((float(f), 0.05, 0.15) for f in np.geomspace(8.0, 30.0, 6))
"""Mode starts ``(freq_hz, zeta_p, zeta_z)`` of the time-domain check of a ``structural_mode``
beside the ``J`` fit's: lightly damped, 8-30 Hz."""


def _time_domain_mode_starts(x_null: np.ndarray) -> list[np.ndarray]:
    """Starts of the output-error refit of a ``structural_mode`` besides its ``J`` fit's: the
    start ``x_null`` (output-error layout: the effect on the null refit's servo and rotor
    term) with its mode set to each of :data:`_TD_MODE_STARTS`.  ``J`` drops
    the response's points below the coherence threshold, and gusts put a mode above 10 Hz
    there, so its ``J`` fit (and the refit started from it alone) lands elsewhere although
    the time histories show it (seed-89 case_033: a 16.0 Hz mode at damping 0.038, the
    coherence under 0.6 from 12 Hz, ``J`` at the true mode 2.10 against the nominal's 1.96;
    the ``J`` fit 4.5 Hz, its refit 5.4 Hz; from these starts 15.4 Hz).  The refit refines
    only the one closest to the records (``screened``): refining all six made the blind
    study's median case 24 % slower (38.9 -> 48.4 s, seed 113) and changed no case there."""
    out = []
    for mode in _TD_MODE_STARTS:
        x = np.array(x_null, float)
        x[3:6] = np.log(mode)
        out.append(x)
    return out


_DELAY_NEGLIGIBLE_S = 1e-3
"""The longest delay a time-domain refit reports that is no delay (:func:`_vanished`): a
tenth of the vocabulary's shortest (10 ms) and of the sample interval of 100 Hz records.
Fresh seed 455's case_059, a paper ``none``, was called ``time_delay`` on the time-domain
path by a refit at 0.12 ms (output error cut 0.3 % at p 2.5e-4, held-out z 1.13): the
servo and rotor term moving, not a delay.  Every other time-domain delay of the stored
draws 367-455 that stood in fitted 11.9-20.5 ms."""


_MODE_NEGLIGIBLE_RATIO = 1.05
"""How close a ``structural_mode``'s zero and pole damping may lie (their ratio, either
way) for the pair to be no resonance (:func:`_vanished`): at 1.05 its peak or notch is
0.4 dB; the vocabulary's weakest resonance has a ratio of 1.25 (1.9 dB), and the
resonances named on the time-domain path in the stored draws 367-455 fitted 1.7-32.
Fresh seed 455's case_059, a paper ``none``, passed there with a 3.02 Hz pair at pole
damping 0.0199 and zero damping 0.0200 (output error p 8.7e-4, held-out z 1.27)."""


def _vanished(effect: str, params: dict) -> bool:
    """Whether a time-domain refit stopped where ``effect`` vanishes: on the side of its
    search box where it does (:data:`_Z_NEUTRAL`: no delay, none longer than
    :data:`_DELAY_NEGLIGIBLE_S`; a gyro filter at the box's 100 Hz; the least flapping
    lag), or, for a structural mode, inside the box with its zero and pole damping equal
    (within :data:`_MODE_NEGLIGIBLE_RATIO`): the pair cancels."""
    if effect == "time_delay":
        return params["delay_s"] <= _DELAY_NEGLIGIBLE_S
    if effect == "structural_mode":
        return abs(math.log(params["zeta_z"] / params["zeta_p"])) < math.log(_MODE_NEGLIGIBLE_RATIO)
    if effect == "sensor_lag":
        return math.log(params["cutoff_hz"]) >= _Z_NEUTRAL[1] - 1e-6
    if effect == "rotor_flapping":
        return params["tau_f"] <= _FLAP_LO_TIME_DOMAIN_S * (1.0 + 1e-6)
    return False


def _airframe_pair(mode: Mapping[str, float], structure_zeta_z: float) -> bool:
    """Whether a fitted ``structural_mode`` (its ``params``) is an extra pole pair of the
    airframe rather than a resonance of the vocabulary: real zeros (zero damping above
    ``structure_zeta_z``), or a frequency below the vocabulary's box (``_Z_LO``, 3 Hz),
    where no effect lies but a flybar's coupled flapping does (the structure step's box
    reaches down to 1 Hz, ``_Z_LO_STRUCTURE``).  ``structure_zeta_z = inf`` switches the
    structure step off, so then neither counts."""
    if math.isinf(structure_zeta_z):
        return False
    return mode["zeta_z"] > structure_zeta_z or math.log(mode["freq_hz"]) < _Z_LO[3]


_Z_FLYBAR_START = np.log([2.0, 0.2, 0.9])
"""Where :func:`rank`'s second start puts a structure finding's pair: below the vocabulary's
box, where the R-50 ``none`` cases of the stored blind seeds fitted it (1.56-1.88 Hz, pole
damping 0.17-0.25, zeros 0.55-1.12)."""

_LAG_BESIDE_FLYBAR_SEARCH = 10.0
"""The factor the paper parameters may move from a structure finding's fit in that second
start (2 in the first, and the polish a factor 4 beyond): beside a pair pressed up to 7.6 Hz
by a 25 ms flapping lag the rotor term's ``tau`` is 0.70, beside the flybar's pair and the
lag 0.054 (noise-free R-50, a factor 13)."""


def _below_vocabulary(mode: Mapping[str, float]) -> bool:
    """Whether a structure finding's pair lies below the vocabulary's 3 Hz floor (``_Z_LO``),
    or on it (within 0.1 % in frequency: a fit the box stopped there)."""
    return math.log(mode["freq_hz"]) < _Z_LO[3] + 1e-3


_AIRFRAME_LEAST_ZETA_P = 0.15
"""The least pole damping of an airframe pair above the vocabulary's floor
(:func:`_resonance_taken_for_structure`): the vocabulary's resonances are drawn at
0.02-0.08.  Over the structure findings of the stored blind seeds (113, 131, 137, 149,
151, 157, 163) the pairs at the flybar's 1.4-2.1 Hz fitted pole damping 0.10-0.28, those
above the floor (4.9-11.7 Hz, where a lag, a delay or a saturation pressed the R-50's
pair up, and two paper plants') 0.155-0.77, but for two true R-50 resonances, 17.6 Hz at
0.07 and 18.0 Hz at 0.03 (zeros 8.8 and 7.6).  On fresh seeds 199 and 211 three more true
R-50 resonances took the pair at 0.108-0.134 (199/057: 11.5 Hz at 0.127 for a 10.4 Hz
mode; 199/071: 14.4 Hz at 0.134 for 12.3; 211/024: 12.3 Hz at 0.108 for 11.1), the
pressed pairs 0.26-0.75: at 0.1 the first and third were found beside that pair at 8.4
and 9.0 Hz and the second not at all; at 0.15 (session 43) all three at 10.5, 13.4 and
11.2 Hz (in-sample)."""


def _resonance_taken_for_structure(mode: Mapping[str, float]) -> bool:
    """Whether a structure finding's pair is a lightly damped pole pair above the
    vocabulary's 3 Hz floor (pole damping below :data:`_AIRFRAME_LEAST_ZETA_P`): a
    resonance whose zeros ran to the structure box's top rather than an airframe pair."""
    return not _below_vocabulary(mode) and mode["zeta_p"] < _AIRFRAME_LEAST_ZETA_P


def _pair_pressed_up(mode: Mapping[str, float]) -> bool:
    """Whether a structure finding's pair lies above the vocabulary's 3 Hz floor, where no
    flybar's coupled flapping lies (:func:`_below_vocabulary`): a resonance whose zeros ran
    to the structure box's top (:func:`_resonance_taken_for_structure`) or an airframe pair
    that an effect pressed up, broad.  :func:`diagnose` then refits the pair below the
    floor with a resonance beside it (:func:`fit_flybar_and_resonance`); a broad pair is
    replaced only where that refit found a pair under the floor (:func:`_under_the_floor`).

    Until session 63 only a lightly damped pair counted, since the pairs that a lag, a
    delay or a saturation pressed up had fitted pole damping 0.155-0.77.  But a true R-50
    resonance presses the one pair up broad just as often (3-5 Hz at pole damping
    0.45-0.85, zeros 1.3-2.8: 435/055, 437/070, 439/019, 441/039), and a resonance fitted
    beside that pair at its frequency predicts the held-out records worse (held-out z -0.7
    to -2.9).  A broad pair is replaced where the refit earns its three parameters on
    ``J`` (:class:`DiagnoseSettings`' ``alpha_pressed_pair``, where the 76 rediagnosed
    cases are counted); the saturations, gyro filters and other delays among them keep
    their verdicts whatever the level."""
    return not _below_vocabulary(mode)


def _under_the_floor(mode: Mapping[str, float]) -> bool:
    """Whether the pair :func:`fit_beside_flybar` refitted lies under the vocabulary's 3
    Hz floor and off it (by 0.1 % in frequency): on it, the top of that refit's box, the
    pair is pressed against the box, not a flybar's.  Of the 76 cases in
    :func:`_pair_pressed_up`'s rediagnosis, 25 refitted a broad pair onto 3.00 Hz; taken
    there as the structure, two R-50 resonances were answered ``rotor_flapping`` with a lag
    of 0-2 ms beating noise (389/063, 433/018) and a third ``structural_mode`` at 5.6 Hz
    for 11.5 (441/039).  A lightly damped pair (:func:`_resonance_taken_for_structure`) is
    replaced by one on the edge as before (seed-149 case_004: 3.0 Hz, and the 16.7 Hz mode
    beside it named)."""
    return math.log(mode["freq_hz"]) < _Z_LO[3] - 1e-3


def fit_beside_flybar(objective, x_structure: np.ndarray, candidates, z_structure: np.ndarray, key,
                      **kw) -> list[LinearFit]:
    """The linear ``candidates`` (each with the structure's ``structural_mode``) refitted on
    ``J`` from a structure finding's paper parameters ``x_structure`` (free by a factor
    :data:`_LAG_BESIDE_FLYBAR_SEARCH`) with its pair started on the flybar's
    (:data:`_Z_FLYBAR_START`) and held below the vocabulary's 3 Hz floor, the candidates'
    own effect coordinates started where ``z_structure`` has them.  The second start of
    the candidates on top of a structure pair above that floor (``diagnose``'s ``rank``).
    ``kw``: :func:`fit_linear_candidates`'s ``wolves``, ``iterations``,
    ``dependence_factor``, ``held_z``."""
    z_hi = np.r_[_Z_HI_STRUCTURE[:3], _Z_LO[3], _Z_HI_STRUCTURE[4:]]
    return fit_linear_candidates(objective, x_structure, candidates, key, search_factor=_LAG_BESIDE_FLYBAR_SEARCH,
                                 effect_seed=np.r_[np.asarray(z_structure)[:3], _Z_FLYBAR_START], z_hi=z_hi,
                                 z_lo=_Z_LO_STRUCTURE, **kw)  # fmt: skip


def _on_vocabulary_floor(mode: Mapping[str, float], structure_zeta_z: float) -> bool:
    """Whether a ``structural_mode`` fitted in the vocabulary's box (its ``params``) stopped on
    that box's 3 Hz floor (:data:`_Z_LO`), below which no effect lies but a flybar's coupled
    flapping does: the pair there is pressed against the floor, not fitted (seed-149
    case_044, an R-50 with a 9.6 Hz gyro filter: 3.0 Hz, pole damping 0.42, zeros 0.91,
    ranked first and beating noise; no structure step, so the filter went on top of the
    paper model alone and predicted the held-out records worse than the nominal).  Never
    with the structure step switched off (``structure_zeta_z = inf``)."""
    return not math.isinf(structure_zeta_z) and _below_vocabulary(mode)


def _broad_pair(mode: Mapping[str, float]) -> bool:
    """Whether a fitted ``structural_mode`` (its ``params``) is a broad pole pair, pole
    damping above :data:`_MODE_AGREEMENT_ZETA_P`: no lightly damped resonance of the
    vocabulary (:func:`_broad_pairs_refused`), but what an airframe's extra pair or a lag
    bends the response into."""
    return mode["zeta_p"] > _MODE_AGREEMENT_ZETA_P


def _structure_route(ranking: Sequence[CandidateScore], fits: dict, structure_zeta_z: float,
                     alpha: float) -> str | None:
    """Where the structure step starts, from the paper model's ranking.

    ``"mode"``: the top candidate is a ``structural_mode`` with real zeros (zero damping
    above ``structure_zeta_z``): an extra pole pair of the airframe; or one stopped on the
    3 Hz floor of the vocabulary's box (:func:`_on_vocabulary_floor`), or a broad pair
    (:func:`_broad_pair`), which the structure step refits in its wider box and keeps only
    where that refit is an airframe pair (a broad pair it does not keep then beats noise
    no more: :func:`_broad_pairs_refused`).  An R-50 backlash drawn for this check
    (seed 2005's case_011) had a 3.1 Hz pair at pole damping 0.37 and zeros 0.99 on top:
    the verdict ``structural_mode``; refitted so, the pair is the airframe's at 1.57 Hz and
    the backlash the verdict on top of it.
    ``"behind_delay"``: the top candidate is a ``time_delay``, behind which such a mode
    may hide.  ``"behind_nonlinearity"``: the top candidate is a nonlinearity and ``J``
    finds an airframe pair below it at ``alpha`` (:func:`_pair_behind_nonlinearity`), which
    the structure step takes as ``"mode"`` takes the top one.  ``None``: no structure step.
    ``"mode"`` and ``"behind_delay"`` need the top candidate to have beaten noise, and
    ``"behind_nonlinearity"`` the pair to have been found, by its frequency-domain fit
    (``J``, in ``fits``), which the step extends: a candidate that won by the time-domain
    path did so with a different model (its output-error refit), whose spec and held-out
    predictions do not belong to that ``J`` fit.
    """
    if not ranking or not ranking[0].beats_noise or ranking[0].detail.get("time_domain_path"):
        return None
    top = ranking[0]
    if _pair_behind_nonlinearity(ranking, fits, structure_zeta_z, alpha) is not None:
        return "behind_nonlinearity"
    if top.effects not in fits:
        return None
    if top.effects == ("structural_mode",) and (_airframe_pair(top.params["structural_mode"], structure_zeta_z)
                                                or _on_vocabulary_floor(top.params["structural_mode"], structure_zeta_z)
                                                or not math.isinf(structure_zeta_z)
                                                and _broad_pair(top.params["structural_mode"])):
        return "mode"
    if top.effects == ("time_delay",):
        return "behind_delay"
    return None


def _pair_behind_nonlinearity(ranking: Sequence[CandidateScore], fits: dict, structure_zeta_z: float,
                              alpha: float) -> CandidateScore | None:
    """The airframe pair a nonlinearity at the head of ``ranking`` takes the top place
    from: the ``structural_mode`` candidate, where ``J`` finds it (:func:`_j_finds` at
    ``alpha``; its ``J`` fit, not the time-domain path, and in ``fits``), it is an airframe
    pair (:func:`_airframe_pair`) and fits ``J`` better than that nonlinearity; else
    ``None``.  ``J`` alone: the held-out records are the nonlinearity's, and the pair
    without it need not raise their R^2 (seed-157 case_065 and 461/043: ``J`` p 8e-7 and
    3e-8, held-out z -0.09 and 0.00).  The mirror of
    :func:`_nonlinearity_over_pair`: there a nonlinearity that fits ``J`` better than the
    pair is what the pair imitated; here the pair is what ``J`` sees and the nonlinearity,
    bent round the pair the paper model lacks, fits ``J`` 10-15 times worse, so the
    nonlinearity is ranked again on top of the pair.

    An R-50 saturation scored on the paper model alone otherwise leaves its held-out R^2
    far below the true model's: 16 R-50 saturations of the fresh blind draws 131-547 had no
    structure finding, each named right and each more than 0.02 short (0.902-0.950 against
    0.958-0.999, their reports' case tables).  On seeds 541 and 543 (case_066 and
    case_045) the pair is at 3.2 Hz, pole damping 0.5, zero damping 1.38 and 1.30, ``J``
    15.1 and 18.4 at p 1e-10 and 6e-8, against the saturation's 220 and 185.  Rediagnosed
    on this rule (the older fourteen re-simulated from their seeds), all sixteen take the
    step and stay ``saturation``, and fifteen come within 0.02 of the true model (0.955-0.989;
    543/045 0.974 for 0.995).  In the stored rankings of seeds 539-547, of the 93 cases
    whose top candidate on the paper model is a nonlinearity that beats noise, no other
    has a ``structural_mode`` ``J`` finds as an airframe pair (the two others whose mode beat
    noise fitted zero damping 0.64 and 0.03, resonances)."""
    top = ranking[0] if ranking else None
    if top is None or not top.beats_noise or len(top.effects) != 1 or top.effects[0] not in NONLINEAR:
        return None
    for c in ranking[1:]:
        if (c.effects == ("structural_mode",) and _j_finds(c, alpha) and not c.detail.get("time_domain_path")
                and c.effects in fits and _airframe_pair(c.params["structural_mode"], structure_zeta_z)
                and c.cost_J < top.cost_J):
            return c
    return None


def _train_mse(spec: ModelSpec, pairs) -> float:
    """Mean squared output error of ``spec`` simulated on ``pairs`` ``(t, u, u_off, y)``;
    ``inf`` where the simulation is not finite."""
    err = np.concatenate([y - simulate_model(spec, t, u) for t, u, _o, y in pairs])
    return float(np.mean(err**2)) if np.all(np.isfinite(err)) else math.inf


def _simulates(spec: ModelSpec, pairs) -> bool:
    return math.isfinite(_train_mse(spec, pairs))


def _time_pairs(records: Sequence[FlightRecord], channel: str, settings: IdentifySettings):
    """``(t, u, u_off, y)`` per record for time-domain fits and scores, each signal taken
    relative to its trim (the mean of the first 0.5 s, at most a tenth of the record);
    ``u_off`` is ``None`` when the record has no off-axis cyclic.

    Not detrended: a detrended input no longer starts at zero, and a model simulated
    from rest would answer that spurious initial step with a transient the aircraft never
    flew (on a short 3-2-1-1 record it costs several hundredths of R^2)."""
    other = "longitudinal" if channel == "lateral" else "lateral"
    off_name = CHANNELS[other][0]
    out = []
    for rec in records:
        u, y = channel_signals(rec, channel)
        t = np.asarray(rec.time, float) - float(rec.time[0])
        uo = _relative_to_trim(rec[off_name], rec.sample_rate) if off_name in rec.columns else None
        out.append((t, _relative_to_trim(u, rec.sample_rate), uo, _relative_to_trim(y, rec.sample_rate)))
    return out


def _relative_to_trim(x, sample_rate: float) -> np.ndarray:
    """``x`` less its trim value: the mean of its first 0.5 s, at most a tenth of the record."""
    x = np.asarray(x, float)
    n0 = max(1, min(int(round(0.5 * float(sample_rate))), x.size // 10))
    return x - float(np.mean(x[:n0]))


_DELAY_GRID_S = np.arange(0.0, _Z_HI[0] + 1e-9, 0.005)
"""Trial delays (s) of the delay-aware WLS start: every 5 ms across the delay's search box."""


#: the stages :func:`diagnose` reports to its ``progress`` callback, in order (the fourth
#: runs only when a structure finding asks for the effects to be ranked again)
DIAGNOSE_STAGES = ("nominal", "where", "which", "which, on top of the extra mode", "how far")


def diagnose(
    train: Sequence[FlightRecord],
    validation: Sequence[FlightRecord],
    channel: str,
    settings: DiagnoseSettings = DiagnoseSettings(),
    progress: Callable[[int, str], None] | None = None,
) -> Diagnosis:
    """Diagnose the gap between the paper model and the records of ``channel``.

    ``train`` identifies (nominal and candidates); ``validation`` is held out and only
    scored.  Raises ``ValueError`` for missing validation records or columns.
    ``progress(done, note)``, when given, is called between stages (``done`` of
    :data:`DIAGNOSE_STAGES`), never from compiled code; it does not change the result.
    """

    def tick(done: int, note: str) -> None:
        if progress is not None:
            progress(done, note)

    if not validation:
        raise ValueError("diagnose needs held-out validation records (--validate VAL): the ranking is scored on them.")
    if not train:
        raise ValueError("diagnose needs at least one identification record.")
    rates = {round(float(r.sample_rate), 6) for r in (*train, *validation)}
    if len(rates) != 1:
        raise ValueError(
            f"the records have different sample rates ({', '.join(f'{r:g}' for r in sorted(rates))} Hz); "
            "diagnose simulates every record at one rate: resample them to one rate."
        )
    ids = settings.identify
    key = jax.random.key(settings.seed)
    tick(0, "nominal: the paper model on TRAIN")
    nominal = identify_channels({channel: list(train)}, ids, validation=list(validation))[channel]
    prep = _prepare(list(train), channel, ids)
    model = nominal.model
    p_true = np.asarray(model.to_array(), float)
    p_norm = p_true * np.array([prep.sign, 1, 1, 1, 1])
    x_nom = np.log(p_norm)
    resp = nominal.response
    dt = 1.0 / float(train[0].sample_rate)

    # -- where
    tick(1, "where: bands, residual tests, amplitude dependence")
    fm = frequency_mismatch(resp, np.asarray(model.frequency_response(resp.w)), nsigma=settings.nsigma)
    tv = _time_pairs(validation, channel, ids)
    tt = _time_pairs(train, channel, ids)
    nom_spec = ModelSpec(p_true)
    val_raw = [simulate_model(nom_spec, t, u) for t, u, _o, _y in tv]
    nominal_simulates = all(np.all(np.isfinite(v)) for v in val_raw)
    val_nom = [np.nan_to_num(v, nan=0.0, posinf=0.0, neginf=0.0) for v in val_raw]
    val_meas = [y for *_r, y in tv]
    resid = [y - p for y, p in zip(val_meas, val_nom)]
    rt = residual_tests([u for _t, u, _o, _y in tv], resid, dt)
    have_off = all(o is not None and np.ptp(o) > 0 for _t, _u, o, _y in tv + tt)
    off_rt = residual_tests([o for _t, _u, o, _y in tv], resid, dt) if have_off else None
    amp = amplitude_dependence([(u, y) for _t, u, _o, y in tt], 1.0 / dt,
                               np.asarray(resp.w), coherence_threshold=ids.coherence_threshold)  # fmt: skip
    nlb = noise_limited_bands(resp)
    gyro = _gyro_path(train, channel, tt, 1.0 / dt, np.asarray(resp.w), ids.coherence_threshold)
    # a gyro filter the attitude shows is measured there: its candidate is fitted with that cutoff
    held = {1: math.log(gyro.cutoff_hz)} if _gyro_filter_held(gyro, settings.alpha) else None
    _y, _p, r2_nom, tic_nom, _gap = held_out_fit(val_meas, val_nom, 0.0)

    # -- which
    skipped: dict[str, str] = {}
    cands = [c for c in settings.candidates if c in EFFECTS]
    if "cross_coupling" in cands and not have_off:
        cands.remove("cross_coupling")
        skipped["cross_coupling"] = (
            f"the records have no varying off-axis input {CHANNELS['longitudinal' if channel == 'lateral' else 'lateral'][0]!r}; "
            "cross-coupling needs it"
        )
    m = float(np.sum(np.asarray(resp.mask)))
    m_eff = max(independent_points(resp), 1.0)
    dep = math.sqrt(m / m_eff)
    k_lin, k_comb, k_nl = jax.random.split(key, 3)
    sign_vec = np.array([prep.sign, 1, 1, 1, 1])
    tc = rt.correlation_time_s if math.isfinite(rt.correlation_time_s) else dt
    fs = 1.0 / dt
    n_train_eff = max(2.0, sum(y.size for *_r, y in tt) * dt / max(tc, dt))

    def sim_J(spec: ModelSpec) -> float:
        """``J`` of the response estimated from ``spec``'s simulated identification output."""
        return simulated_response_cost(prep.objective, [(u, simulate_model(spec, t, u, o)) for t, u, o, _y in tt],
                                       fs, np.asarray(resp.w), prep.sign, ids)  # fmt: skip

    def score(base: _Base, effects, params, sigma, spec, cost, J0, n_params, baseline=None, extra_p=None, j_required=True,
              evidence=None, time_domain=False, alpha=None, confirm=True, predicted=None, veto=True,
              gap_against_baseline=False, held_out_alpha=None, as_linear=False, j_resonance=False):
        """``predicted``: ``spec``'s held-out simulation where it is at hand already.
        ``veto=False``: the held-out records score the candidate but cannot refuse it.
        ``gap_against_baseline``: as :func:`score_candidate`'s.  ``as_linear``: the held-out
        records need only not contradict it, as for a linear ``J`` fit (``z_min``,
        ``min_gap``; :func:`_held_out_floor`): a resonance two tests find.  ``j_resonance``:
        a candidate's ``J`` fit, which takes that floor where it is a resonance ``J`` finds
        (:func:`_resonance_found_by_j`)."""
        pred = [simulate_model(spec, t, u, o) for t, u, o, _y in tv] if predicted is None else list(predicted)
        ag = float(np.mean([_agreement(e, fm, amp, off_rt, params.get(e)) for e in effects]))
        a = settings.alpha if alpha is None else alpha

        def held_out(floor):
            z_min, min_gap = floor
            return score_candidate(tuple(effects), params, sigma, pred, val_meas, base.val_predicted, base.val_r2, cost,
                                   J0, m_eff, n_params, tc, dt, ag, baseline_predicted=baseline, extra_train_p=extra_p,
                                   j_required=j_required, evidence=evidence, alpha=a,
                                   z_min=z_min if veto else -math.inf, min_gap=min_gap if veto else -math.inf,
                                   gap_against_baseline=gap_against_baseline,
                                   held_out_alpha=held_out_alpha)  # fmt: skip

        sc = held_out(_held_out_floor(settings, effects, time_domain, confirm, as_linear))
        if j_resonance and not sc.beats_noise and veto and _resonance_found_by_j(effects, params, sc, a):
            sc = held_out(_held_out_floor(settings, effects, time_domain, confirm, as_linear=True))
            if sc.beats_noise:  # marked here, where the floor is chosen
                sc = dataclasses.replace(sc, detail={**sc.detail, "passed_as_resonance_found_by_J": 1.0})
        return sc

    def rank(base: _Base, names: Sequence[str], k_lin, k_nl, stage: int, what: str, prior=None):
        """Every candidate of ``names`` added to ``base``, refitted and scored against it.
        Returns the scores, the fitted model of each candidate (keyed by its own effects),
        its frequency-domain fit and start (keyed by all the effects fitted), the linear
        candidates' output-error refits, and the null refit (:class:`TimeDomainRefit`, or
        ``None`` without candidates).
        ``prior`` maps the effects of a frequency-domain fit made before (a structure found
        behind a delay: the mode and the delay fitted together) to that fit and its start;
        it replaces the candidate's own refit where it fits ``J`` better."""
        tick(stage, f"{what}: linear candidates (frequency domain)")
        scored: list[CandidateScore] = []
        specs: dict = {}
        output_error: dict = {}  # a linear candidate's time-domain refit, where J decides it
        obj0, x0, seed0, _sv = base.start
        lin_names = [base.linear + (c,) for c in names if c in FREQUENCY_DOMAIN and c not in base.linear]
        # on top of a structure finding its mode keeps the structure step's wider box
        z_hi, z_lo = (_Z_HI_STRUCTURE, _Z_LO_STRUCTURE) if base.linear else (None, None)
        lin = fit_linear_candidates(obj0, x0, lin_names, k_lin, wolves=settings.wolves, iterations=settings.iterations,
                                    dependence_factor=dep, effect_seed=seed0, z_hi=z_hi, z_lo=z_lo, held_z=held)  # fmt: skip
        # (objective, start, effect seed, sign vector) each linear candidate was refitted from
        lin_from = {f.effects: base.start for f in lin}
        if not base.linear and ("time_delay",) in lin_from:
            # a long delay can throw the delay-free nominal fit (and the refit searched around
            # it) far off, even to the wrong gain sign: refit from a delay-aware start as well
            i_td = [f.effects for f in lin].index(("time_delay",))
            ds = delay_aware_start(prep.response, prep.objective, prep.sign, _DELAY_GRID_S,
                                   ids.sk_iterations)  # fmt: skip
            if ds is not None and ds.cost_J < lin[i_td].cost_J:
                obj = prep.objective if ds.sign == prep.sign else _flipped_objective(prep.objective)
                seed = np.r_[ds.delay_s, _Z_NEUTRAL[1:]]
                (f_td,) = fit_linear_candidates(obj, ds.x, [("time_delay",)], jax.random.fold_in(k_lin, 1),
                                                wolves=settings.wolves, iterations=settings.iterations,
                                                dependence_factor=dep, effect_seed=seed)  # fmt: skip
                if f_td.cost_J < lin[i_td].cost_J:
                    lin[i_td] = f_td
                    lin_from[("time_delay",)] = (obj, ds.x, seed, np.array([ds.sign, 1, 1, 1, 1]))
        if base.linear == ("structural_mode",) and lin and not _below_vocabulary(base.spec.effects["structural_mode"]):
            # A structure finding above the vocabulary's floor, with real zeros, is often a lag
            # the paper model took as a pole pair: a flapping lag of 15-25 ms on the noise-free
            # R-50 presses the pair to 7.6-8.1 Hz (zeros 4.0, the rotor term's tau 0.40-0.69),
            # where beside the lag it lies on the flybar's 1.8 Hz and tau is the R-50's 0.05-0.06.
            # Around the finding's paper parameters (the polish reaches a factor 8) that fit is
            # out of reach; each linear candidate is refitted from the flybar's pair as well,
            # with the paper parameters free by a factor 10 (_LAG_BESIDE_FLYBAR_SEARCH), and
            # the better J kept.  Seed-151 case_053 (R-50, 24.5 ms lag; pair at 8.7 Hz): the
            # verdict time_delay becomes rotor_flapping.
            low = fit_beside_flybar(obj0, x0, lin_names, seed0, jax.random.fold_in(k_lin, 11), wolves=settings.wolves,
                                    iterations=settings.iterations, dependence_factor=dep, held_z=held)  # fmt: skip
            lin = [g if g.cost_J < f.cost_J else f for f, g in zip(lin, low, strict=True)]
        for i, f in enumerate(lin):
            if prior and f.effects in prior and prior[f.effects][0].cost_J < f.cost_J:
                lin[i], lin_from[f.effects] = prior[f.effects]
        fits = {f.effects: f for f in lin}
        refit = None
        nl_names = [c for c in names if c in NONLINEAR]
        td_names = [c for c in names if c in NONLINEAR or c == "cross_coupling"]
        if names:
            # the time-domain candidates are tested against the null refit: the paper model
            # refitted by output error, without any effect (the frequency-domain base is a
            # poorer output-error model, and beating it is no evidence for an effect); the
            # linear candidates are checked against it as well
            tick(stage, f"{what}: {', '.join(td_names + ['linear checks'] if lin else td_names)} (time domain)")
            td_base = base.spec
            if not base.linear and not _simulates(base.spec, tt):
                # A long delay can drive the delay-free nominal to a model no simulation
                # survives (seed-41 case_041, 30 ms: servo at 3e7 rad/s, damping 1e-4), and a
                # refit from there stays non-finite (the null's error NaN, its residual tests
                # warning on NaN input).  The time-domain fits then start from the paper part
                # of the linear refit that simulates best; nothing else changes.  Without
                # linear candidates (settings.candidates) the paper part of the delay-aware
                # WLS start stands in for them.
                alts = [ModelSpec(np.exp(f.x[:5]) * lin_from[f.effects][3]) for f in lin]
                if not alts:
                    ds = delay_aware_start(prep.response, prep.objective, prep.sign, _DELAY_GRID_S,
                                           ids.sk_iterations)  # fmt: skip
                    alts = [] if ds is None else [ModelSpec(np.exp(ds.x) * np.array([ds.sign, 1, 1, 1, 1]))]
                errs = [_train_mse(a, tt) for a in alts]  # inf where it does not simulate
                if any(math.isfinite(e) for e in errs):
                    td_base = alts[int(np.argmin(errs))]
            *nl, null = fit_nonlinear_candidates(td_base, tt, nl_names, k_nl, include_null=True,
                                                 free_mode=bool(base.linear),
                                                 **_nonlinear_budget(settings))  # fmt: skip
            null_spec = null.spec(td_base)
            specs[()] = td_base  # where the time-domain fits started (the combined step's too)
            val_null = [simulate_model(null_spec, t, u) for t, u, _o, _y in tv]
            refit = _time_domain_refit(null, null_spec, val_null, val_meas, base.val_r2)
            # effective samples of the identification output error from its own correlation time
            tr_res = [y - simulate_model(null_spec, t, u) for t, u, _o, y in tt]
            tc_tr = residual_tests([u for _t, u, _o, _y in tt], tr_res, dt).correlation_time_s
            n_nl = max(8.0, sum(y.size for *_r, y in tt) * dt / max(tc_tr, dt))

        def time_domain_check(base, own, sc, z, x, fit_base, fitted, held, mode_starts, z_hi=None):
            """The time-domain check of the linear candidate ``own`` (score ``sc``): the
            effects ``fitted`` (those of ``held`` kept where ``z`` has them) refitted by
            output error on ``fit_base`` from the ``J`` fit ``x`` (effect coordinates
            ``z``) and from ``z`` on the null refit's servo and rotor term, and scored
            against the null refit.  Returns the entry of ``lin_scores``."""
            nul = null.refit
            k = sum(len(EFFECTS[e].params) for e in own)
            x_j = _output_error_start(z, x)
            x_n = np.r_[z, np.log([nul["omega_s"], nul["zeta_s"], nul["tau"], nul["M"]])]
            tdf = refit_linear_time_domain(fit_base, tt, fitted, [x_j, x_n], held=held, z_hi=z_hi,
                                           screened=_time_domain_mode_starts(x_n) if mode_starts else ())  # fmt: skip
            if tdf is None:  # no start simulates: the J verdict stands alone
                return own, sc, None, None, {"time_domain_path": 0.0, "td_failed": 1.0}
            td_spec = tdf.spec(fit_base)
            p_td = f_test_p(null.train_mse, tdf.train_mse, k, n_nl - 4 - k)
            det_mf = {}
            matched = mode_starts and not fit_base.fixed_modes and _resonance_in_box(tdf.params["structural_mode"])
            if matched:
                # a resonance on the paper model alone: its evidence is the matched filter's
                # (_resonance_in_box); td_p_output_error below is then its p, td_p_f_test the F-test's
                td_res = [y - simulate_model(td_spec, t, u) for t, u, _o, y in tt]
                z_mf = matched_filter_z(tr_res, td_res, 1.0 / dt)
                det_mf = {"td_mf_z": z_mf, "td_p_f_test": p_td}
                p_td = matched_filter_p(z_mf, k)
            ev = output_error_evidence(null.train_mse, tdf.train_mse, k, n_nl)
            # J and the matched filter finding one resonance are two independent tests that
            # agree: the refit then needs the held-out records only not to contradict it
            agree = matched and _same_resonance(sc, tdf.params["structural_mode"], settings.alpha)
            strong = _matched_filter_alone(matched, agree, p_td, settings.alpha_resonance)
            if agree:
                # ranked on J's evidence where that is the larger: the gusts that dominate the
                # output error leave a resonance a small share of it (seed-181 case_063: J
                # 25.1 -> 4.3 at 8.53 Hz, the refit 0.06 per effective sample, behind a 58 ms
                # flapping lag's J 26.7 -> 12.5)
                ev = max(ev, j_evidence(sc.delta_bic, k, m_eff))
            sc_td = score(base, own, {e: tdf.params[e] for e in own}, {e: tdf.sigma[e] for e in own}, td_spec,
                          sim_J(td_spec), base.cost_J_sim, k, baseline=val_null, extra_p=p_td, j_required=False,
                          evidence=ev, time_domain=True, confirm=not (agree or strong), as_linear=agree)  # fmt: skip
            if agree:
                det_mf["td_resonance_found_by_J"] = 1.0
            if strong and sc_td.beats_noise and not sc_td.z_score > settings.z_min_time:
                det_mf["td_passed_on_matched_filter_alone"] = 1.0
            det = {"td_train_mse": tdf.train_mse, "null_train_mse": null.train_mse, "td_p_output_error": p_td,
                   "td_z_score": sc_td.z_score, "td_gap_closed": sc_td.gap_closed, "td_val_r2": sc_td.val_r2,
                   "td_beats_noise": float(sc_td.beats_noise), "time_domain_path": 0.0}  # fmt: skip
            det |= {f"td_{p}": v for e in own for p, v in tdf.params[e].items()} | det_mf
            return own, sc, sc_td, td_spec, det

        def second_pole_pair(base, k_pair):
            """A resonance beside a structure finding's pole pair: that pair held where the
            structure step fitted it (:attr:`ModelSpec.fixed_modes`; on ``J`` through
            :func:`with_fixed_modes`), the resonance fitted in the vocabulary's box with the
            paper parameters, then the pair refitted beside it and the resonance beside
            that (below), scored against the base and checked in the time domain as the
            other linear candidates are.  The structure step fills the one
            ``structural_mode`` of the effect coordinates, and without this no resonance on
            an R-50 could be the verdict (0/9 over the stored blind seeds).  A fit that
            stops on an edge of its box (:func:`_on_box_edge`) is scored but cannot beat
            noise, and its output-error refit cannot stand in for it
            (:func:`_refit_may_stand_in`)."""
            obj, x0, z_pair, sv = base.start
            pair = _mode_tuple(base.spec.effects["structural_mode"])
            own = ("structural_mode",)
            f, fixed = fit_resonance_beside_pair(obj, x0, pair, z_pair, k_pair, settings.structure_zeta_z,
                                                 wolves=settings.wolves, iterations=settings.iterations,
                                                 dependence_factor=dep)  # fmt: skip
            spec = ModelSpec(np.exp(f.x[:5]) * sv, f.params, fixed_modes=fixed)
            specs[own] = spec
            edge = _on_box_edge(f.params["structural_mode"])
            sc = score(base, own, f.params, f.sigma, spec, f.cost_J, base.cost_J, 3, extra_p=1.0 if edge else None,
                       j_resonance=True)  # fmt: skip
            # The time-domain check holds the pair where the null refit holds it, the
            # structure step's: refitted beside the resonance it has moved on the
            # identification records, three parameters the output error's F-test would not
            # count (R-50 none cases of seed 137, 036 and 066: resonances at 4.7 and 4.1 Hz,
            # pole damping 0.19 and 0.18, passed at output-error p 6e-8 and 4e-14 beside the
            # refitted pair; beside the held one they stop on the box's edge, as before).
            fit_base = ModelSpec(td_base.params, {}, td_base.gain_scale, (pair,))
            own, sc, sc_td, td_spec, det = time_domain_check(base, own, sc, f.x[5:], f.x, fit_base, own, (), True,
                                                             _Z_HI_SECOND_PAIR)  # fmt: skip
            # the pair the resonance lies beside (refitted or held), which the model needs too
            det |= {"second_pole_pair": 1.0, "on_box_edge": float(edge)}
            det |= dict(zip(("pair_freq_hz", "pair_zeta_p", "pair_zeta_z"), map(float, fixed[0])))
            td_mode = None if sc_td is None else sc_td.params["structural_mode"]
            if td_mode is not None and not _refit_may_stand_in(f.params["structural_mode"], td_mode):
                det["td_on_box_edge"] = float(_on_box_edge(td_mode))
                sc_td, td_spec, det["td_refused_on_box_edge"] = None, None, 1.0
            return own, sc, sc_td, td_spec, det

        lin_scores = []
        for f in lin:
            own = f.effects[len(base.linear) :]
            sv = lin_from[f.effects][3]
            spec = ModelSpec(np.exp(f.x[:5]) * sv, f.params)
            specs[own] = spec
            k = sum(len(EFFECTS[e].params) for e in own)
            if held is not None and "sensor_lag" in own:
                # The gyro filter's cutoff is the attitude's measurement (gyro_path): the evidence
                # for it, and its 1-sigma half the range there.  That evidence is the gyro
                # against the attitude, independent of the plant model, so the held-out records
                # say how far the filter closes the gap but do not refuse it: on top of an R-50
                # structure finding the extra pole pair had absorbed the filter, and adding it
                # back lowered the held-out R^2 (seed-89 case_047: a 27.0 Hz filter measured at
                # 27.3, p 8e-160, held-out R^2 0.986 -> 0.984, z -2.3, the verdict none).  No
                # output-error refit: it would move the cutoff.
                lo_c, hi_c = gyro.cutoff_range_hz
                sig = {"sensor_lag": {"cutoff_hz": 0.5 * (hi_c - lo_c) if math.isfinite(hi_c) else math.inf}}
                sc = score(base, own, {e: f.params[e] for e in own}, sig, spec, f.cost_J, base.cost_J, k,
                           extra_p=gyro.p_value, j_required=False, veto=False)  # fmt: skip
                if not base.linear:
                    # the model handed over: its servo and rotor term refitted by output error
                    # with the cutoff held at the gyro path's (_gyro_filter_model)
                    gm = _gyro_filter_model(td_base, tt, f.x)
                    if gm is not None:
                        g_spec = gm.spec(td_base)
                        output_error[own] = (score(base, own, dict(gm.params), sig, g_spec, math.nan, base.cost_J_sim, k,
                                                   extra_p=gyro.p_value, j_required=False, veto=False), g_spec)  # fmt: skip
                lin_scores.append((own, sc, None, None, {"time_domain_path": 0.0, "cutoff_from_gyro_path": 1.0}))
                continue
            # on a structure finding a lag's or delay's J F-test is conservative (DiagnoseSettings:
            # alpha_lag_on_structure)
            level = max(settings.alpha, settings.alpha_lag_on_structure) \
                if base.linear and own in _LEVEL_ON_STRUCTURE else None
            sc = score(base, own, {e: f.params[e] for e in own}, {e: f.sigma[e] for e in own}, spec, f.cost_J,
                       base.cost_J, k, j_resonance=True, alpha=level)  # fmt: skip
            # The time-domain check: the same effect refitted by output error against the null
            # refit, from the J fit and from that effect on the null's servo and rotor term.
            # J weights the response's coherent points, the output error the input's power;
            # the nominal's absorbed servo can hide from J an effect that cuts the output
            # error (seed-41 case_037: a 11.6 Hz gyro filter at J p = 0.025).  It passes as the
            # nonlinear candidates do (F-test at alpha, confirmed on VAL against the null
            # refit) but without their effect size: on the 24 none cases of seeds 41, 31 and 79
            # the linear refits changed the null's error by x0.975-1.002 (smallest p 0.014),
            # on case_037 cut it by x1.013 at p 1e-17.  It decides where J finds no linear
            # effect at all, or stands in for a J fit the held-out records refuse although J
            # finds the effect (_takes_time_domain_path).
            # A structure finding's mode is held where the null refit holds it (refitted here
            # alone it cut a seed-31 R-50 none case's error by x1.05 with a "lag" at 100 Hz).
            z = np.where(_active_mask(base.linear), seed0, f.x[5:]) if base.linear else f.x[5:]
            mode_starts = own == ("structural_mode",) and not base.linear
            lin_scores.append(time_domain_check(base, own, sc, z, f.x, td_base, f.effects, base.linear, mode_starts))
        if base.linear == ("structural_mode",) and "structural_mode" in names:
            lin_scores.append(second_pole_pair(base, jax.random.fold_in(k_lin, 7)))
        # a resonance J alone carries near its threshold on the paper model (_resonance_on_j_alone)
        for i, (own, sc, sc_td, td_spec, det) in enumerate(lin_scores):
            if own == ("structural_mode",) and not base.linear and sc.beats_noise and _resonance_on_j_alone(
                    sc.train_p, det.get("td_p_output_error"), settings.alpha, settings.alpha_resonance_j_alone):
                # the mark goes in det, which becomes the candidate's detail below
                lin_scores[i] = (own, _refused(sc), sc_td, td_spec, det | {"refused_as_resonance_on_J_alone": 1.0,
                                                                  "level_j_alone": settings.alpha_resonance_j_alone})
        # a linear effect J finds at alpha (not one passed at the structure's level only)
        j_found = any(sc.beats_noise and sc.train_p < settings.alpha for _o, sc, *_r in lin_scores)
        for own, sc, sc_td, td_spec, det in lin_scores:
            if sc_td is not None:
                det["td_p_J_worse"] = j_worse_p(sc_td, m_eff)
            if sc.detail.get("passed_as_resonance_found_by_J"):  # score() chose that floor
                det["passed_as_resonance_found_by_J"] = 1.0
            if sc.beats_noise and not sc.train_p < settings.alpha:
                det["passed_at_structure_level"] = 1.0
            if _takes_time_domain_path(sc, sc_td, j_found, settings.alpha, settings.structure_zeta_z, m_eff=m_eff):
                sc, specs[own] = sc_td, td_spec
                det["time_domain_path"] = 1.0
            elif sc_td is not None:
                output_error[own] = (sc_td, td_spec)
            scored.append(dataclasses.replace(sc, detail=det))
        if "cross_coupling" in names:
            # the off-axis gain in closed form on top of the null refit; its error is compared
            # with the null's as simulated by the same linear model
            cc = fit_cross_coupling(null_spec, tt)
            spec = ModelSpec(null_spec.params, dict(null_spec.effects) | cc.params, null_spec.gain_scale)
            specs[("cross_coupling",)] = spec
            # about each record's mean, as the null refit's own error and cc.train_mse are
            mse_null = float(np.mean(np.concatenate([r - np.mean(r) for r in tr_res]) ** 2))
            g, sg = cc.params["cross_coupling"]["gain"], cc.sigma["cross_coupling"]["gain"]
            p_cc = math.erfc(abs(g / sg) / math.sqrt(2.0)) if sg > 0 else 1.0  # two-sided, Bartlett's sigma
            ev = output_error_evidence(mse_null, max(cc.train_mse, 1e-300), 1, n_nl)
            # as for a nonlinearity: a large cut needs the held-out records only not to contradict
            # it; so does a gain far beyond noise on the paper model alone (DiagnoseSettings:
            # alpha_coupling_gain), which held-out multisteps cannot confirm
            cut = mse_null >= settings.strong_error_ratio * cc.train_mse
            by_gain = not cut and not base.linear and p_cc < settings.alpha_coupling_gain
            strong = cut or by_gain
            sc = score(base, ("cross_coupling",), cc.params, cc.sigma, spec, sim_J(spec), base.cost_J_sim, 1,
                       baseline=val_null, extra_p=p_cc, j_required=False, evidence=ev, time_domain=True,
                       confirm=not strong, held_out_alpha=settings.alpha_held_out_first or None)  # fmt: skip
            if sc.beats_noise and not p_cc < settings.alpha:  # the held-out records carried it
                sc = dataclasses.replace(sc, detail={"passed_on_held_out_records": 1.0})
            elif sc.beats_noise and by_gain and not sc.z_score > settings.z_min_time:  # the gain carried it
                sc = dataclasses.replace(sc, detail={"passed_on_gain_alone": 1.0})
            scored.append(sc)
        if nl_names:
            # the null refit's own J, which a nonlinearity's J is tested against (below); the
            # score's J0 stays the base's
            j_null = sim_J(null_spec)

            def nonlinear_score(f, nul, val_nul, j_nul):
                """The score of the nonlinear fit ``f`` against the null refit ``nul`` (its
                held-out prediction ``val_nul`` and ``J`` ``j_nul``), and its model."""
                spec = f.spec(td_base)
                p_mse = f_test_p(nul.train_mse, f.train_mse, 1, n_nl - 4)
                # Gusts dominate the output error, so a real servo nonlinearity may cut it by only
                # a few per cent.  Trust a small cut when the frequency-domain amplitude test,
                # independent of the output-error fit, shows the change with amplitude this
                # effect predicts; otherwise ask for an effect size (a mild clipping fits
                # gust-induced error significantly).
                corroborated = _amplitude_agreement(f.effects[0], amp) > 0.0
                level = settings.alpha_amplitude if corroborated else settings.alpha
                ev = output_error_evidence(nul.train_mse, f.train_mse, 1, n_nl)
                # an effect that cuts the null refit's identification error by a large factor
                # needs the held-out records only not to contradict it, as a linear one does
                strong = nul.train_mse >= settings.strong_error_ratio * f.train_mse
                # The candidate is the null refit with the nonlinearity added.  Where that refit
                # predicts the held-out records worse than the frequency-domain base (an R-50's
                # extra pole pair, fitted to J, carries model-form error the output-error fit
                # does not share), the effect's gain on them shows against the refit alone:
                # seed-113 case_020, an R-50 rate limit at output-error p 4e-67 (error cut
                # x1.37, the amplitude test agreeing), raised the refit's held-out R^2
                # 0.966 -> 0.976 (z 1.06) below the pair model's 0.981 and was refused.  That
                # gap may then be the refit's, but only for evidence that passes without the
                # amplitude test's backing: F-test at alpha and the effect size.
                plain = p_mse < settings.alpha and nul.train_mse >= settings.min_error_ratio * f.train_mse
                j_f = sim_J(spec)
                # J against the null refit's J: a second test of the nonlinearity on the
                # identification records, on the response's coherent points, which gusts do not
                # dominate as they do the output error; passed at alpha, it is evidence and
                # effect size both, and the held-out records need only not contradict it
                # (as for a large error cut).  The null refit, a linear model fitted to time
                # histories a rate limit distorts, fits J far worse than one with the limit:
                # seed-181 case_011, 33.3 against 1.19 (the rate 3.15 for 3.12).  Set on the
                # paper-plant rate limits answered `none` of the fresh draws 131-181 (four of
                # 13 found since: 151/046, 163/009, 173/041, 179/030).  On the 16 `none` cases
                # of seeds 179 and 181 none passes it in the final ranking (smallest p 4e-3, an
                # R-50; on paper plants the J ratio to the null refit's is 0.88 or more); on the
                # paper model before an R-50's structure finding a saturation does (p 2e-6 to
                # 8e-5: it bends round the missing pole pair), and the pair outranks it.
                # It counts only with an effect size (DiagnoseSettings: j_null_ratio): a
                # resonance near the sweeps' top passed it as a rate limit at 0.64-0.69.
                p_j_null = j_f_test_p(j_nul, j_f, 1, m_eff)
                j_strong, p_id = _against_null_j(p_mse, p_j_null, j_f, j_nul, settings.alpha, settings.j_null_ratio)
                # Two independent tests on the identification records, the amplitude test's
                # backing and the output-error F-test at alpha itself (not alpha_amplitude),
                # need the held-out records only not to contradict it either
                # (_amplitude_backed)
                by_amplitude = not (strong or j_strong) and _amplitude_backed(corroborated, p_mse, settings.alpha)
                strong = strong or j_strong or by_amplitude
                kw = dict(j_required=False, evidence=ev, time_domain=True, alpha=level, confirm=not strong,
                          gap_against_baseline=plain)
                sc = score(base, f.effects, f.params, f.sigma, spec, j_f, base.cost_J_sim, 1, baseline=val_nul,
                           extra_p=p_id, **kw)  # fmt: skip
                acts = None if f.mode is not None else nonlinearity_acts(spec, tv, sc.predicted)

                def effect_size(amplitude_counts: bool) -> bool:
                    if f.mode is not None:  # on a structure finding, its pair refitted beside it
                        return _pair_free_effect_size(nul.train_mse / f.train_mse, settings.pair_free_error_ratio,
                                                      amplitude_counts, j_f, j_nul)  # fmt: skip
                    return j_strong or _effect_size_passes(nul.train_mse / f.train_mse, settings.min_error_ratio,
                                                           amplitude_counts, sc.delta_bic_val, acts,
                                                           settings.held_out_bic)  # fmt: skip

                sizes = _amplitude_sizes(corroborated, by_amplitude, sc.z_score, settings.z_min_time)
                sized = effect_size(sizes)
                # where _amplitude_sizes alone refused the size (the amplitude test's agreement
                # would have sized it), say so, so that the rule's refusals count exactly
                amplitude_refused = not sized and corroborated and not sizes and effect_size(True)
                if not sized:  # significant perhaps, but too small an effect to trust
                    sc = score(base, f.effects, f.params, f.sigma, spec, j_f, base.cost_J_sim, 1, baseline=val_nul,
                               extra_p=1.0, predicted=sc.predicted, **kw)  # fmt: skip
                det = {"train_mse": f.train_mse, "null_train_mse": nul.train_mse, "n_eff_train": n_nl,
                       "train_corr_time_s": tc_tr, "p_val_tc": f_test_p(nul.train_mse, f.train_mse, 1, n_train_eff - 4),
                       "p_output_error": f_test_p(nul.train_mse, f.train_mse, 1, n_nl - 4),
                       "amplitude_corroborates": float(corroborated), "effect_size_passes": float(sized),
                       "confirmed_against_null_refit_only": float(sc.beats_noise and not sc.gap_closed > 0.0),
                       "null_cost_J": j_nul, "p_J_null": p_j_null}  # fmt: skip
                if by_amplitude and sc.beats_noise and not sc.z_score > settings.z_min_time:
                    det["passed_on_amplitude_backing"] = 1.0  # the held-out records did not confirm it
                if amplitude_refused:  # _amplitude_sizes: the backing already counted as evidence
                    det["amplitude_refused_as_size"] = 1.0
                if f.mode:  # the structure finding's pair as refitted beside the nonlinearity
                    det |= {f"pair_{q}": v for q, v in f.mode.items()}
                else:
                    det["acts_on_held_out"] = float(acts)
                return dataclasses.replace(sc, detail=det), spec

            # On a structure finding each nonlinearity is also refitted with the pair free
            # (fit_nonlinear_candidates' free_mode) and tested against a null refit given the
            # same freedom: the pair-held fit is scored as before, and where it does not beat
            # noise the pair-free one may, on the stricter effect size of
            # _pair_free_effect_size.  Where both beat noise, the pair-free fit is the model
            # where its refitted pair cuts the identification error at alpha
            # (_pair_refit_stands).
            against = next((f.against for f in nl if f.against is not None), None)
            if against is not None:
                a_spec = against.spec(td_base)
                val_against, j_against = [simulate_model(a_spec, t, u) for t, u, _o, _y in tv], sim_J(a_spec)
            for f in nl:
                sc, spec = nonlinear_score(f.held or f, null, val_null, j_null)
                if f.held is not None:
                    sc_f, spec_f = nonlinear_score(f, f.against, val_against, j_against)
                    p_pair = _refitted_pair_p(f.held.train_mse, f.train_mse, n_nl)
                    if _pair_refit_stands(sc.beats_noise, sc_f.beats_noise, p_pair, settings.alpha):
                        sc = dataclasses.replace(sc_f, detail=sc_f.detail | {"pair_held_train_mse": f.held.train_mse,
                                                                             "pair_refit_p": p_pair})  # fmt: skip
                        spec = spec_f
                specs[f.effects] = spec
                scored.append(sc)
        return scored, specs, fits, lin_from, output_error, refit

    base0 = _Base(nom_spec, (), (prep.objective, x_nom, None, sign_vec), float(nominal.cost_J), sim_J(nom_spec), val_nom,
                  r2_nom)  # fmt: skip
    scored, specs, fits, lin_from, output_error, refit = rank(base0, cands, k_lin, k_nl, 2, "which")
    ranking = _lag_over_delay(sorted(scored, key=_best_first), settings.lag_over_delay)

    # -- structure: an extra pole pair the paper model lacks is the airframe's, not an effect
    structure, paper_ranking = None, ()
    route = _structure_route(ranking, fits, settings.structure_zeta_z, settings.alpha)
    if route in ("mode", "behind_nonlinearity"):
        structure = ranking[0] if route == "mode" else \
            _pair_behind_nonlinearity(ranking, fits, settings.structure_zeta_z, settings.alpha)
        others, paper_ranking = tuple(c for c in ranking if c is not structure), ranking
        f_sm = fits[("structural_mode",)]
        sm_spec = specs[("structural_mode",)]
        # The vocabulary's box caps the damping (pole 0.5, zeros 1.5) where a resonance lies;
        # a missing pole pair often fits on that cap (R-50: J 34.6 there, 9.5 at zeros 3.5
        # and poles 0.47), or on its 3 Hz floor below which a flybar's coupled flapping lies.
        # The mode is refitted from where it stopped in the wider box of _Z_LO_STRUCTURE and
        # _Z_HI_STRUCTURE, and kept where that fits J better, still beats noise and still
        # has real zeros or lies below the vocabulary's resonances (no effect lies there: a
        # seed-89 R-50's 3 Hz pair at zeros 1.5 refitted to 1.8 Hz at zeros 0.9, J 13.3 ->
        # 7.7).
        obj_s, _x, _s, sv_s = lin_from[("structural_mode",)]
        (f_w,) = fit_linear_candidates(obj_s, f_sm.x[:5], [("structural_mode",)], jax.random.fold_in(key, 2),
                                       wolves=settings.wolves, iterations=settings.iterations, dependence_factor=dep,
                                       effect_seed=f_sm.x[5:], z_hi=_Z_HI_STRUCTURE,
                                       z_lo=_Z_LO_STRUCTURE)  # fmt: skip
        if f_w.cost_J < f_sm.cost_J:
            w_spec = ModelSpec(np.exp(f_w.x[:5]) * sv_s, f_w.params)
            w_sc = score(base0, ("structural_mode",), f_w.params, f_w.sigma, w_spec, f_w.cost_J, base0.cost_J, 3)
            if w_sc.beats_noise and _airframe_pair(f_w.params["structural_mode"], settings.structure_zeta_z):
                f_sm, sm_spec, structure = f_w, w_spec, w_sc
                paper_ranking = tuple(sorted((w_sc, *others), key=_best_first))
        # a lightly damped pair is always refitted beside the flybar; a broad one only where
        # it may be replaced (DiagnoseSettings: alpha_pressed_pair, 0 off)
        light = _resonance_taken_for_structure(structure.params["structural_mode"])
        if not _airframe_pair(structure.params["structural_mode"], settings.structure_zeta_z):
            # a mode on the vocabulary's floor whose wider refit is no airframe pair either
            structure, paper_ranking = None, ()
        elif _pair_pressed_up(structure.params["structural_mode"]) and (light or settings.alpha_pressed_pair > 0):
            # A pole pair above the vocabulary's floor is a resonance whose zeros ran to the
            # structure box's top, or an airframe pair an effect pressed up, lightly damped or
            # broad (on the R-50 `none` cases of the stored blind seeds the pair lay at
            # 1.56-1.88 Hz, pole damping 0.17-0.25; _pair_pressed_up).  The airframe pair is
            # refitted below the floor (fit_beside_flybar)
            # and a resonance beside it (fit_resonance_beside_pair); where the two fit J
            # better than the pair alone, that pair is the structure finding, and the
            # resonance is a candidate on top of it like any other (second_pole_pair).
            # Seed-149 case_004 (R-50, 16.5 Hz mode): pair 17.6 Hz, poles 0.07, zeros 8.8,
            # J 10.8; below the floor 3.0 Hz, J 36.7, with the resonance beside it 4.3 and the
            # verdict `none` -> `structural_mode` at 16.7 Hz.  Seed-137 case_009 (15.6 Hz):
            # 18.0 Hz, poles 0.03, J 14.0 -> 1.68 Hz, resonance at 15.8 Hz, J 4.9.
            f_b, f_r = fit_flybar_and_resonance(obj_s, f_sm.x, jax.random.fold_in(key, 5), wolves=settings.wolves,
                                                iterations=settings.iterations, dependence_factor=dep)  # fmt: skip
            b_spec = ModelSpec(np.exp(f_b.x[:5]) * sv_s, f_b.params)
            b_sc = score(base0, ("structural_mode",), f_b.params, f_b.sigma, b_spec, f_b.cost_J, base0.cost_J, 3)
            # A broad pair (pressed up) only where the two earn their three parameters on J
            # and the refit lies under the floor (DiagnoseSettings: alpha_pressed_pair).
            low = f_b.params["structural_mode"]
            earned = j_f_test_p(f_sm.cost_J, f_r.cost_J, 3, m_eff) < settings.alpha_pressed_pair
            if (f_r.cost_J < f_sm.cost_J and b_sc.beats_noise and _airframe_pair(low, settings.structure_zeta_z)
                    and (light or (earned and _under_the_floor(low)))):
                # the pair it replaces, kept in its detail (the airframe's pair pressed up)
                pressed = f_sm.params["structural_mode"]["freq_hz"]
                f_sm, sm_spec = f_b, b_spec
                structure = dataclasses.replace(b_sc, detail={**b_sc.detail, "pressed_pair_hz": pressed})
                paper_ranking = tuple(sorted((structure, *others), key=_best_first))
        if structure is not None:
            # a nonlinearity that fits J better than the pair the step would take is what the
            # pair imitated: no structure, the nonlinearity first (_nonlinearity_over_pair)
            over = _nonlinearity_over_pair(ranking, structure)
            if over[0] is not ranking[0]:
                ranking, structure, paper_ranking = over, None, ()
        if structure is not None and route == "behind_nonlinearity":
            structure = dataclasses.replace(structure, detail={**structure.detail, "found_behind_nonlinearity": 1.0})
        obj_s, sv_s, prior = prep.objective, sign_vec, None
    elif route == "behind_delay":
        # A long delay takes the top place from the extra pole pair an airframe such as the
        # R-50's needs (seed-113 R-50 delays of 50 and 67 ms: no structure found, the delay
        # off by 9 ms, the held-out R^2 0.83-0.88 against the true model's 0.99+).  The mode
        # is fitted on top of the delay in the structure step's box; where it beats noise
        # against the delay alone and is an airframe pair (_airframe_pair) it is a structure
        # finding, and the effects are ranked on top of it.
        top, f_top = ranking[0], fits[("time_delay",)]
        obj_t, _x, _s, sv_t = lin_from[("time_delay",)]
        pair = ("structural_mode", "time_delay")
        (f_p,) = fit_linear_candidates(obj_t, f_top.x[:5], [pair], jax.random.fold_in(key, 4), wolves=settings.wolves,
                                       iterations=settings.iterations, dependence_factor=dep, effect_seed=f_top.x[5:],
                                       z_hi=_Z_HI_STRUCTURE, z_lo=_Z_LO_STRUCTURE)  # fmt: skip
        base_t = _Base(specs[("time_delay",)], ("time_delay",), lin_from[("time_delay",)], f_top.cost_J, math.nan,
                       list(top.predicted), top.val_r2)  # fmt: skip
        sm_p = {"structural_mode": f_p.params["structural_mode"]}
        sc_p = score(base_t, ("structural_mode",), sm_p, {"structural_mode": f_p.sigma["structural_mode"]},
                     ModelSpec(np.exp(f_p.x[:5]) * sv_t, f_p.params), f_p.cost_J, f_top.cost_J, 3)  # fmt: skip
        if sc_p.beats_noise and _airframe_pair(sm_p["structural_mode"], settings.structure_zeta_z):
            # the base is the pair without its delay, not a refit of the mode alone: without
            # the delay the mode drifts to imitate it (seed-41 case_006: zero damping 2.0 ->
            # 0.02, a dipole); the delay's candidate on top starts from the pair (prior)
            sm_only = _active_mask(("structural_mode",))
            x_s = np.r_[f_p.x[:5], np.where(sm_only, f_p.x[5:], _Z_NEUTRAL)]
            cost_s = float(AugmentedCifer.from_cifer(obj_t, sm_only)(jnp.asarray(x_s)))
            sig_p = {"structural_mode": f_p.sigma["structural_mode"]}
            f_sm = LinearFit(("structural_mode",), x_s, cost_s, sm_p, sig_p)
            sm_spec = ModelSpec(np.exp(x_s[:5]) * sv_t, sm_p)
            structure = score(base0, ("structural_mode",), sm_p, sig_p, sm_spec, cost_s, base0.cost_J, 3)
            structure = dataclasses.replace(structure, detail={"found_behind_time_delay": 1.0,
                                                               "z_score_over_time_delay": sc_p.z_score})
            paper_ranking = ranking
            obj_s, sv_s, prior = obj_t, sv_t, {pair: (f_p, lin_from[("time_delay",)])}
    if structure is not None:
        base_s = _Base(sm_spec, ("structural_mode",), (obj_s, f_sm.x[:5], f_sm.x[5:], sv_s), f_sm.cost_J,
                       sim_J(sm_spec), list(structure.predicted), structure.val_r2)  # fmt: skip
        k_lin_s, k_nl_s = jax.random.split(jax.random.fold_in(key, 1))
        scored, specs, fits, lin_from, _oe, refit = rank(base_s, cands, k_lin_s, k_nl_s, 3,
                                                         "which, on top of the extra mode", prior=prior)  # fmt: skip
        ranking = tuple(sorted(scored, key=_best_first))  # no lag_over_delay on top of the mode: see its docstring
        if settings.alpha_lag_on_structure:  # a delay below the vocabulary's is a lag's
            ranking = _lag_over_short_delay(ranking)
    ranking = _gyro_path_order(_broad_pairs_refused(_switched_off_refused(ranking)), gyro, settings.alpha)
    ranking = _failing_by_evidence(_nonlinearity_by_j(ranking, settings.nonlinearity_by_j),
                                   _gyro_filter_held(gyro, settings.alpha) if gyro.tested else None)
    if structure is not None and settings.flapping_between_airframes:
        ranking = _flapping_between_airframes(ranking, fits, lin_from)
    verdict = ranking[0].effects[0] if ranking and ranking[0].beats_noise else "none"
    if structure is None:
        # a gyro filter's model handed over is its output-error refit (_output_error_estimate)
        ranking = tuple(_paper_estimate(sc, output_error.get(sc.effects)) for sc in ranking)
        specs |= {sc.effects: output_error[sc.effects][1] for sc in ranking if sc.detail.get("estimate_output_error")}
    else:
        ranking = tuple(_airframe_bracket(sc, fits, lin_from) for sc in ranking)

    # -- how far: the top two combined
    tick(4, "how far: the top two combined")
    combined = None
    if structure is not None and ranking:
        # the top two are the extra mode and the best effect on top of it, fitted together
        top = ranking[0]
        pair = ("structural_mode", *top.effects)
        spec = specs[top.effects]
        k2 = 3 + top.n_params
        params = {e: dict(spec.effects[e]) for e in pair}
        sigma = {"structural_mode": structure.sigma["structural_mode"]} | dict(top.sigma)
        if pair in fits:
            combined = score(base0, pair, params, sigma, spec, fits[pair].cost_J, base0.cost_J, k2)
        else:
            combined = score(base0, pair, params, sigma, spec, sim_J(spec), base0.cost_J_sim, k2,
                             j_required="cross_coupling" not in pair)  # fmt: skip
    elif len(ranking) >= 2:
        a, b = ranking[0].effects[0], ranking[1].effects[0]
        pair = (a, b)
        k2 = sum(len(EFFECTS[e].params) for e in pair)
        if a in FREQUENCY_DOMAIN and b in FREQUENCY_DOMAIN:
            obj, x0, seed, sv = lin_from[("time_delay",)] if "time_delay" in pair else lin_from[(a,)]
            (f,) = fit_linear_candidates(obj, x0, [pair], k_comb, wolves=settings.wolves, iterations=settings.iterations,
                                         dependence_factor=dep, effect_seed=seed, held_z=held)  # fmt: skip
            spec = ModelSpec(np.exp(f.x[:5]) * sv, f.params)
            combined = score(base0, pair, f.params, f.sigma, spec, f.cost_J, base0.cost_J, k2)
            # with a gyro filter, estimated as it is alone: the pair's output-error refit from its J
            # fit, the cutoff held where the gyro path measured it (_gyro_filter_model) with its bound
            td_base = specs.get((), nom_spec)
            hold = ("sensor_lag",) if held is not None else ()
            tdf = None if "sensor_lag" not in pair else refit_linear_time_domain(
                td_base, tt, pair, [_output_error_start(f.x[5:], f.x)], held=hold)  # fmt: skip
            if tdf is not None:
                td_spec = tdf.spec(td_base)
                sig_td = dict(tdf.sigma)
                if hold:  # the cutoff's bound is the gyro path's, as the filter alone quotes it
                    sig_td["sensor_lag"] = dict(next(sc.sigma["sensor_lag"] for sc in ranking[:2]
                                                     if "sensor_lag" in sc.effects))  # fmt: skip
                sc_td = score(base0, pair, tdf.params, sig_td, td_spec, math.nan, base0.cost_J_sim, k2)
                combined = _output_error_estimate(combined, (sc_td, td_spec))
        else:
            # no joint refit across domains: the nonlinear or cross-coupling part is refitted
            # with the project's optimiser on top of the linear part's refitted model
            lin_part = [e for e in pair if e in FREQUENCY_DOMAIN]
            # without a linear part, start where the ranking's time-domain fits did (the
            # nominal, or a model that simulates where the nominal does not)
            base = specs[(lin_part[0],)] if lin_part else specs.get((), nom_spec)
            eff = dict(base.effects)
            gain_scale = base.gain_scale
            sigma = {e: ranking[i].sigma.get(e, {}) for i, e in enumerate(pair)}
            nl_part = [e for e in pair if e in NONLINEAR]
            if nl_part:
                (f,) = fit_nonlinear_candidates(base, tt, nl_part[:1], k_comb, **_nonlinear_budget(settings))
                base = f.spec(base)
                eff, gain_scale = dict(base.effects), base.gain_scale
                sigma |= f.sigma
                if len(nl_part) == 2:  # the second nonlinearity as fitted alone
                    eff |= {nl_part[1]: specs[(nl_part[1],)].effects[nl_part[1]]}
            if "cross_coupling" in pair:
                cc = fit_cross_coupling(ModelSpec(base.params, eff, gain_scale), tt)
                eff["cross_coupling"] = cc.params["cross_coupling"]
                sigma |= cc.sigma
            spec = ModelSpec(base.params, eff, gain_scale)
            params = {e: dict(eff[e]) for e in pair}
            combined = score(base0, pair, params, sigma, spec, sim_J(spec), base0.cost_J_sim, k2,
                             j_required="cross_coupling" not in pair)  # fmt: skip

    suggestion = separation_suggestion(ranking, settled=[frozenset(_LAGS)] if gyro.tested else [])
    tick(len(DIAGNOSE_STAGES), "done")
    return Diagnosis(
        channel=channel,
        nominal_params={k: float(v) for k, v in zip(("K", "tau", "M", "omega_s", "zeta_s"), p_true)},
        nominal_cost_J=float(nominal.cost_J), nominal_r2=r2_nom, nominal_tic=tic_nom,
        mismatch=fm, residuals=rt, off_axis_residuals=off_rt, amplitude=amp, noise_limited_bands_hz=nlb,
        ranking=ranking, verdict=verdict, combined=combined, skipped=skipped, structure=structure,
        paper_ranking=paper_ranking, nominal_simulates=nominal_simulates, gyro=gyro,
        unconfirmed=_unconfirmed(ranking, verdict, settings.alpha),
        val_time=tuple(t for t, *_r in tv), val_measured=tuple(val_meas), val_nominal=tuple(val_nom),
        response_w=np.asarray(resp.w), suggestion=suggestion, refit=refit,
    )  # fmt: skip


def _proposed_model(d: Diagnosis) -> tuple[CandidateScore | None, str]:
    """The model the diagnosis proposes and its legend label: the verdict's candidate (on
    top of a structure finding's pole pair, which its prediction includes), else the paper
    model with that pair, else none (the nominal stands).  Not the top of the ranking when
    the verdict is none: that candidate failed, and its held-out fit is not a claim."""
    pair = ()
    if d.structure is not None:
        pair = (f"pole pair {d.structure.params['structural_mode']['freq_hz']:.3g} Hz",)
    if d.verdict != "none" and d.ranking:
        return d.ranking[0], "+" + "+".join(pair + d.ranking[0].effects)
    if d.structure is not None:
        return d.structure, "+" + pair[0]
    return None, ""


def plot_diagnosis(d: Diagnosis, path: str) -> None:
    """Bode mismatch with its bounds and the flagged bands shaded; residual auto- and
    input cross-correlation; before/after overlays on VAL; the candidates' held-out gains;
    where the records log an attitude, the gyro path with its fitted filter."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ._atomic import atomic_savefig
    from ._plots import log_frequency_axis

    fm = d.mismatch
    g = d.gyro
    fig, ax = plt.subplots(4 if g.tested else 3, 2, figsize=(12.0, 14.5 if g.tested else 11.0))
    for a, err, bound, lab in ((ax[0, 0], fm.magnitude_error_db, fm.magnitude_bound_db, "magnitude error (dB)"),
                               (ax[0, 1], fm.phase_error_deg, fm.phase_bound_deg, "phase error (deg)")):  # fmt: skip
        a.plot(fm.f_hz, err, "k.-", ms=3, label="model - measured")
        a.fill_between(fm.f_hz, -fm.nsigma * bound, fm.nsigma * bound, color="0.85", label=f"+-{fm.nsigma:g} sigma random error")
        for lo, hi in fm.bands_hz:
            a.axvspan(lo, hi, color="tab:red", alpha=0.2)
        log_frequency_axis(a)
        a.set_xlabel("frequency (Hz)")
        a.set_ylabel(lab)
        a.legend(fontsize=8)
    r = d.residuals
    ax[1, 0].plot(r.acf_lags_s, r.acf, label="residual autocorrelation")
    ax[1, 0].plot(r.xcorr_lags_s, r.xcorr, label="input-residual cross-correlation")
    ax[1, 0].axhline(r.xcorr_bound, color="0.5", ls=":")
    ax[1, 0].axhline(-r.xcorr_bound, color="0.5", ls=":")
    ax[1, 0].set_xlabel("lag (s)")
    ax[1, 0].legend(fontsize=8)
    ax[1, 1].semilogy(r.psd_f_hz, r.psd)
    ax[1, 1].set_xlabel("frequency (Hz)")
    ax[1, 1].set_ylabel("residual PSD")
    t = d.val_time[0]

    def shown(pred):  # as scored, about the record's mean residual
        return held_out_centred([pred])[0] + float(np.mean(d.val_measured[0]))

    ax[2, 0].plot(t, d.val_measured[0], "k", lw=0.8, label="measured (VAL)")
    ax[2, 0].plot(t, shown(d.val_nominal[0]), "tab:blue", lw=0.8, label=f"nominal R^2 {d.nominal_r2:.3f}")
    proposed, label = _proposed_model(d)
    if d.refit is not None and d.refit.predicted:
        ax[2, 0].plot(t, shown(d.refit.predicted[0]), "tab:green", lw=0.6, ls="--",
                      label=f"refitted by output error, no effect, R^2 {d.refit.val_r2:.3f}")  # fmt: skip
    if proposed is not None:
        ax[2, 0].plot(t, shown(proposed.predicted[0]), "tab:red", lw=0.8, label=f"{label} R^2 {proposed.val_r2:.3f}")
    ax[2, 0].set_xlabel("time (s)")
    ax[2, 0].legend(fontsize=8)
    names = ["+".join(c.effects) for c in d.ranking]
    gains = [c.gap_closed for c in d.ranking]
    colors = ["tab:green" if c.beats_noise else "0.6" for c in d.ranking]
    ax[2, 1].barh(names[::-1], gains[::-1], color=colors[::-1])
    ax[2, 1].set_xlabel("fraction of held-out R^2 gap closed")
    ax[2, 1].set_title(f"verdict: {d.verdict}", fontsize=10)
    if g.tested:
        fit = g.model()
        label = f"first-order filter {g.cutoff_hz:.3g} Hz" if math.isfinite(g.cutoff_hz) else "no filter"
        for a, data, model, lab in ((ax[3, 0], 20 * np.log10(np.abs(g.ratio)), 20 * np.log10(np.abs(fit)),
                                     "gyro path |p / (s phi)| (dB)"),
                                    (ax[3, 1], np.rad2deg(np.angle(g.ratio)), np.rad2deg(np.angle(fit)),
                                     "gyro path phase (deg)")):  # fmt: skip
            a.plot(g.f_hz, data, "k.", ms=3, label="rate over attitude rate")
            a.plot(g.f_hz, model, "tab:red", label=label)
            log_frequency_axis(a)
            a.set_xlabel("frequency (Hz)")
            a.set_ylabel(lab)
            a.legend(fontsize=8)
    fig.suptitle(f"jaxgwo diagnose, {d.channel} channel")
    fig.tight_layout()
    atomic_savefig(fig, path)
    plt.close(fig)

"""Speed and accuracy of the nonlinear frequency-response solvers, compared on equal work.

Run from the repository root::

    python benchmarks/frf_speed.py            # full run
    python benchmarks/frf_speed.py --quick    # 3 repeats, no sequential time integration
    python benchmarks/frf_speed.py --parts 3,4  # some parts only

One module per part (``harmonic_balance`` 1a, ``time_integration`` 1b, ``multi_harmonic`` 1c,
``scaling`` 2, ``grid`` 3, ``predictions`` 4), shared helpers in ``common`` and ``pyharm``.

pyHarm-os is the optional ``benchmark`` extra (it pins pandas < 3); install it in a separate
environment, e.g. ``python -m venv /tmp/bench-venv && /tmp/bench-venv/bin/pip install -e ".[benchmark]"``,
and run the script with that interpreter. Without it Parts 1a and 1c report the project alone.

Every figure printed is measured in this run; nothing is extrapolated. Timings are medians
of N repeats, the same N for every tool of a table, taken interleaved (one call of each tool
per round, the order rotated every round) so that load from other users of a shared machine
hits all tools alike. Each is given as CPU time (this process and its waited-for children;
pyHarm-os: the CPU time of its ``operate()``) beside wall time: the CPU time does not count
the time the core is taken away by other work, which on a loaded shared machine can double
the wall time. Ratios and every goal's met / NOT met are on CPU time, between times of the
same run. The first lines say the machine, the date and the load average; each part states
the load again.

Part 1 — the reference Duffing oscillator ``m ẍ + c ẋ + k x + k3 x³ = F cos ωt`` with
m = 1 kg, c = 0.05 N·s/m, k = 1 N/m, k3 = 1 N/m³, F = 0.5 N, ω ∈ [0.5, 3.5] rad/s.

1a. Harmonic balance like for like: this project against pyHarm-os (one harmonic; pyHarm
    adds the constant term, 64 time samples per period). Both solve the same
    single-harmonic balance, so the accuracy of each point is checked against the exact
    single-harmonic relation ``G(a, ω) = a²[(k − mω² + ¾k3a²)² + (cω)²] − F² = 0``: the
    relative error of the amplitude against the nearest root a(ω) of this cubic in a² at the
    point's own ω (ill-conditioned at a fold, where a(ω) has a vertical tangent), and the
    relative distance of the point from the exact curve, ``|G| / ‖(a ∂G/∂a, ω ∂G/∂ω)‖``
    (first order in the relative perturbation of a and ω; well conditioned at the folds).
    Both tools run at their default tolerances (this project: scaled residual 1e-10;
    pyHarm: scipy ``root`` hybr, xtol 1.49e-8), and the project's grid sweep also at 1e-12,
    which puts it at least as close to the exact curve as pyHarm's; the tables show the
    errors side by side. Two designs:

    (a) the same fixed frequency grid (the 200-point grid below): a stepped sweep up and one
        down, each solution the predictor of the next (pyHarm: previous-solution predictor,
        no continuation, constant step = grid step; this project: Newton at each grid
        frequency from the previous solution, and its own grid API — trace, then
        ``stepped_sine`` polishing on the grid). A fixed-frequency solver started on the
        branch that ends in a fold does not reach the other branch: pyHarm's sweep stalls at
        the first grid frequency past a fold (and so does the project's Newton sweep; the run
        prints where), so the timed sweeps stop at the last grid frequency before the fold
        (up: ω < 3.0290, down: ω > 1.4416; the folds are computed from the cubic).
    (b) continuation with equal point counts over the band: the project's default step
        control (78 points) against pyHarm with a constant arc-length step chosen to give 78
        points, and pyHarm's setting of earlier versions of this benchmark (ds0 = 0.01,
        ds_max = 0.05, step halved/doubled on acceptance: 283 points) against the project
        with ``max_step`` chosen to give about as many. pyHarm's time is its ``operate()``
        (the ``Maestro(...)`` build, a few ms, is excluded and reported apart).

1b. The single-harmonic results against time integration, at equal output: 200 grid
    frequencies swept up and down (400 responses). The project's figure is the trace plus
    ``stepped_sine`` up and down; the others are the seed fixed-point iteration, the
    project's vectorised time integration, and — in the full run only — its sequential
    time-domain stepped sine ``time_sweep`` and scipy ``solve_ivp`` (DOP853, rtol 1e-9) as a
    sequential stepped sine: at each frequency the state of the previous one is carried over
    and one period after the other is integrated until the first harmonic changes by less
    than 1e-6 (relative) in three consecutive periods (at most 2000 periods). These do not
    have equal accuracy: the time integrations include the higher harmonics the
    single-harmonic balance leaves out. Accuracy: relative first-harmonic amplitude error at
    the grid frequencies against ``time_sweep`` up and down (state carried from frequency to
    frequency, so it follows the true multi-harmonic branches like a test); a stable DF point
    is compared with the sweep of the same direction, other results with the nearer of the
    two. Two responses differing by more than 10 % are on different branches (this happens
    only inside the grid cells between a single-harmonic fold and the multi-harmonic one) and
    are counted, not compared. With ``--quick`` the reference is the vectorised integration
    started from the DF points, and the two sequential integrations are not run.

1c. Multi-harmonic balance like for like: ``trace_harmonic_balance`` against pyHarm-os at
    H = 1, 3, 5, 7 (pyHarm ``nh`` = H, harmonics 0 … H for both), the same 64 time samples per
    period (pyHarm ``nti`` = the project's ``samples``; pyHarm's default would be 128) and
    constant-step continuation over the band with (nearly) equal point counts, printed:
    pyHarm stepsizer ``constant``, ds = 0.175, with its default tangent predictor, arc-length
    corrector and scipy ``root`` hybr; the project step = max_step = 0.042 (scaled arc length;
    it halves the step only at a sharp turn or a failed corrector and inserts the refined
    folds). All tools of all H run in the same interleaved rounds (pyHarm's first call, its
    numba JIT, is a warm-up). The like-for-like row is the project with ``stability=False``
    (the sign of det ∂R/∂y, which is what pyHarm computes too: it has no stability analysis,
    only its tangent predictor's fold/branching flag from a sign change of det J); the
    project's Hill stability (``stability=True``; at H = 1 the project keeps the determinant)
    is timed as a separate row and checked against the determinant (a point with det < 0 has
    a real Floquet multiplier above 1, so Hill must not call it stable). At H = 1 the
    describing-function trace at the same step is timed too. Accuracy against time integration: at each curve's points that are stable by
    the determinant and farther than 2 % of the band from the project's folds at that H, the
    project's vectorised RK4 (``steady_state_response``, 512 steps per period, tolerance 1e-10;
    ``--quick`` 256, 1e-9) started from the point's full harmonic-balance state, the steady
    state's harmonics 0 … 7 taken by FFT of the last period: the relative first-harmonic
    amplitude error, and the amplitude error of harmonics 2 … 7 relative to their reference
    norm (harmonics above H count as zero), where they carry at least 0.1 % of |X₁|; max and
    median per curve. pyHarm's points are also put into the project's H-harmonic residual.
    Time per curve and per point and the ratio pyHarm ÷ this project, on CPU-time medians (wall beside).

Part 2 — condensed-solve scaling: a fixed–free spring–mass chain (total mass 1 kg, static
tip stiffness 1e4 N/m, loss factor 0.01) with a cubic spring (1e8 N/m³) and a Jenkins
element (kf = 2e3 N/m, Fs = 0.5 N) from the tip to ground, 5 N at the tip, traced over
[0.7, 2] × its first natural frequency; 10 dofs (dense) against 10,000 dofs (sparse, and
its 20-mode modal model at the tip). The single-harmonic trace and the multi-harmonic one
(``trace_harmonic_balance``, H = 5, default samples and step control, ``stability=False``)
of the 10-dof model and of the 20-mode modal model of the 10,000-dof chain are timed in the
same interleaved rounds; the full run adds one multi-harmonic run with Hill stability of each
of these two models, and one without of the sparse 10,000-dof lumped model (a sparse LU per
frequency and harmonic).
"""

//! Solver settings, statuses and the report of a solve.

use std::time::Duration;

use ddp_core::{Error, LineSearchSettings, Method, RegularizationSettings, Result, Tolerances};

use crate::qp::{QpMethod, QpStats};

/// How a solve reaches the KKT/QP iterations of Xie et al. (2017).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WarmUp {
    /// None: the KKT/QP iterations from the first iteration (the paper's scheme).
    None,
    /// Augmented-Lagrangian iterations: the constraint rows enter the cost as
    /// `(max(0, lambda + rho g)^2 - lambda^2) / (2 rho)`, so the value function sees obstacles
    /// ahead, and the multipliers are updated between inexact inner solves; the KKT/QP
    /// iterations take over once the violation is below [`Settings::al_switch_violation`].
    AugmentedLagrangian,
    /// A cold start first follows a log-barrier homotopy: inexact DDP solves of the cost plus
    /// `-mu sum log(-g)` (relaxed below a slack of [`Settings::barrier_relaxation`]) for `mu`
    /// falling from [`Settings::barrier_mu_init`] to [`Settings::barrier_mu_final`], which keep
    /// the trajectory away from the constraint boundary while the obstacles are being resolved,
    /// as the interior-point methods do (Pavlov, Shames and Manzie 2021; IPOPT). The default
    /// relaxation is wide (a slack of 0.1): below it the barrier is a quadratic penalty, so the
    /// trajectory may cross an obstacle's edge while it chooses its way round, much as IPOPT's
    /// slacks let its iterates violate the rows until they converge. Then the
    /// augmented-Lagrangian iterations and the KKT/QP iterations, with the barrier's multiplier
    /// estimates `mu / -g` as the first multipliers. Warm starts that violate a row use the
    /// augmented Lagrangian.
    Barrier,
    /// A cold start is solved twice from the same initial guess, once with each of the two
    /// warm-ups above, and the better solution is kept (feasible first, then lower cost): the
    /// two homotopies often end in different local optima around the obstacles, and their best
    /// is far more often the best optimum IPOPT or FATROP find (`bench/peers/family.py`). Where
    /// the two end apart ([`Settings::portfolio_apart`]), a third start from another barrier
    /// ([`Settings::portfolio_third_mu`]) and a restart from the kept solution
    /// ([`Settings::portfolio_polish`]) follow; where they agree on a poor cost, the third start
    /// goes on only if its homotopy takes another side of the obstacles
    /// ([`Settings::portfolio_new_side`]). Last, where the kept solution costs well above the
    /// optimum without the constraints, one start per binding obstacle steered to its far side
    /// ([`Settings::portfolio_flip`]). Warm starts and solves with a [`crate::Tightening`] use
    /// [`WarmUp::Barrier`]'s rule.
    Portfolio,
}

impl WarmUp {
    /// The name used in Python and in logs.
    pub fn as_str(&self) -> &'static str {
        match self {
            WarmUp::None => "none",
            WarmUp::AugmentedLagrangian => "augmented_lagrangian",
            WarmUp::Barrier => "barrier",
            WarmUp::Portfolio => "portfolio",
        }
    }
}

/// Settings of [`crate::SafeCddpSolver`]; validated when the solver is built.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// iLQR (Gauss-Newton dynamics) or full DDP (second-order dynamics terms in eq. (5)). Full
    /// DDP takes Gauss-Newton passes in the barrier warm-up's homotopy and its second-order terms
    /// from the hand-over on: far from the solution they add cost and indefiniteness, not
    /// convergence.
    pub method: Method,
    /// Maximum number of iterations of [`crate::SafeCddpSolver::solve`].
    pub max_iterations: usize,
    /// Stopping tests: the projected gradient `sum_k |Q_u + C_W^T lambda|^2` (`gradient`) and the
    /// relative merit change of an accepted step (`cost`), each on a feasible trajectory.
    pub tolerances: Tolerances,
    /// A trajectory is feasible when no (tightened) row exceeds this.
    pub constraint_tolerance: f64,
    /// `epsilon` of the active set: a row with `g~ > -epsilon` enters the backward pass (Xie et al.).
    /// A row farther off its boundary is inactive, so a solve converges only where such rows
    /// carry no multiplier: in the working set of the KKT/QP iterations, and in the augmented
    /// Lagrangian's `min(-g~, lambda / rho) <= epsilon` (Conn, Gould and Toint 1991).
    pub active_threshold: f64,
    /// Regularisation `mu` of `Q_uu + mu I` and its schedule (shared with [`ddp_core::Solver`]).
    pub regularization: RegularizationSettings,
    /// Line search on the merit (shared with [`ddp_core::Solver`]).
    pub line_search: LineSearchSettings,
    /// `rho` of the merit `J + rho sum max(0, g~)` used by the line search.
    pub merit_penalty: f64,
    /// Initial trust-region radius `Delta` on `|du_j|` (infinite: none).
    pub trust_region: f64,
    /// Factor applied to the trust region after an infeasible QP, in (0, 1).
    pub trust_shrink: f64,
    /// Forward passes retried (smaller step and trust region) after an infeasible QP, before the
    /// regularisation is raised.
    pub max_qp_retries: usize,
    /// After the retries, solve infeasible QPs in elastic form (the constraint rows relaxed by a
    /// slack that costs `merit_penalty`), so the pass goes on and the merit decides; `false`
    /// raises the regularisation instead (the paper's scheme). Either way a final trajectory that
    /// violates a row is reported as [`Status::Infeasible`].
    pub elastic: bool,
    /// How the per-step QPs are solved.
    pub qp_method: QpMethod,
    /// Adds the constraint curvature `lambda g_xx` (previous multipliers) to the Hessians, a Newton
    /// model of the Lagrangian. Off by default: for obstacles the curvature is negative definite,
    /// `Q_uu` then often needs heavy regularisation, and on the benchmark problems the
    /// Gauss-Newton model converges better.
    pub constraint_hessian: bool,
    /// Largest relative degree searched for a state-only constraint.
    pub max_relative_degree: usize,
    /// How a solve reaches the KKT/QP iterations of Xie et al. (2017) ([`WarmUp`]). Without a
    /// warm-up, a far-off initial guess can drive the per-step QPs infeasible (a state
    /// constraint can be moved by one control only a little).
    pub warm_up: WarmUp,
    /// Initial barrier parameter `mu` of [`WarmUp::Barrier`] (and of the portfolio's second
    /// start).
    pub barrier_mu_init: f64,
    /// Factor on `mu` after each inexact barrier subproblem, in (0, 1).
    pub barrier_mu_factor: f64,
    /// The barrier homotopy ends once `mu` falls below this.
    pub barrier_mu_final: f64,
    /// Relaxation `delta` of the barrier: below a slack of `delta` the logarithm continues as a
    /// quadratic (Hauser and Saccon 2006), so an infeasible trajectory has a finite merit. The
    /// default `1e-1` with `barrier_mu_init = 3e-2` is a soft barrier, a quadratic penalty of
    /// curvature `mu / delta^2` near and inside the obstacles: on the family replays of six
    /// seeds the portfolio with it matches the peers' best on 1165 of 1260 problems instead of
    /// 1155 with the hard barrier of earlier versions (`barrier_mu_init = 3e-3`,
    /// `barrier_relaxation = 1e-6`), 45 instead of 59 miss by more than 5 %, for 0.95x the
    /// iterations, and alone (`WarmUp::Barrier`) 1031 instead of 934; on a seventh seed
    /// generated afterwards 187 of 210 instead of 182 (`bench/peers/README.md`, "The soft
    /// barrier").
    pub barrier_relaxation: f64,
    /// Most accepted iterations per barrier subproblem.
    pub barrier_inner_iterations: usize,
    /// After the barrier homotopy has handed the augmented Lagrangian a trajectory from the
    /// interior, the largest violation (in the constraints' own units, at least the current
    /// largest) that a trial step may reach at a knot where two or more rows are violated at
    /// once; `f64::INFINITY`: no limit. The barrier chose the way around the obstacles; under
    /// its first, weak penalty the augmented Lagrangian may step into them, which it recovers
    /// from where one row is violated, but inside a wall of overlapping obstacles the rows'
    /// gradients cancel, the violation stalls, and the solve ends on the wrong side (a
    /// point-robot problem of the family ended 164x above the peers' cost that way; with the
    /// funnel it reaches their optimum). The default `3e-2`: on the family replays of six seeds
    /// 1155 of 1260 problems match the peers' best instead of 1147 and 59 miss by more than 5 %
    /// instead of 68, with the same iterations; P2, P3, Table I and the planar quadrotor past
    /// its obstacle (one obstacle each, or none overlapping) solve as without it, bit for bit.
    /// Counting every knot instead (a violation of `3e-2` anywhere) also helped the family
    /// (1150, 57) but cost 7 % more time, and it held the quadrotor's augmented Lagrangian back
    /// (it passes `5e-2` on its way to the optimum) into a neighbouring optimum and 2.6x the
    /// time (`bench/peers/README.md`, "Problem family").
    pub barrier_funnel: f64,
    /// [`WarmUp::Portfolio`]: the initial barrier parameter of a third start, a barrier
    /// homotopy like the second's from this `mu` (falling by `barrier_mu_factor` to
    /// `barrier_mu_final`, or a single subproblem when it is below `barrier_mu_final`), run
    /// where the first two starts end apart ([`Settings::portfolio_apart`]). Another barrier
    /// chooses its way around the obstacles differently and often ends in another optimum.
    /// `None`: no third start. With the default `Some(3e-3)` (one subproblem of the second
    /// start's soft barrier, weaker) and the polish, the family replays of six seeds match the
    /// peers' best on 1165 of 1260 problems instead of 1125 with two starts, for 1.30x the
    /// iterations (`bench/peers/README.md`, "The soft barrier").
    pub portfolio_third_mu: Option<f64>,
    /// [`WarmUp::Portfolio`]: the third start ([`Settings::portfolio_third_mu`]) and the polish
    /// ([`Settings::portfolio_polish`]) run only when the first two starts ended apart: their
    /// costs differ by more than this, relative to the larger (but by less than a factor of 10:
    /// a start that ends further above the other stalled), or either is infeasible. Two starts
    /// that end apart show a problem with several optima within reach of a cold start, where a
    /// third way of choosing among them pays; where they agree (P3, within 1e-10), the extra
    /// starts mostly land on the same optimum. `0`: always.
    pub portfolio_apart: f64,
    /// [`WarmUp::Portfolio`]: when the best start's solution is the augmented Lagrangian's own
    /// (its hand-over to the KKT/QP iterations failed, and it ran to its own convergence), a
    /// last start from that solution, the KKT/QP iterations with cold multipliers and working
    /// sets, kept when better (its iterations and QP counts then add to the kept start's; the
    /// report's log holds the polish's own iterations). Restarted with
    /// cold multipliers, the augmented Lagrangian leaves the contact set it had settled on and
    /// often finds a neighbouring one of lower cost. Like the third start, it runs only where
    /// the first two starts end apart ([`Settings::portfolio_apart`]); `false`: no polish. Run
    /// always (`portfolio_apart = 0`), it also runs on P2 and P3 (whose kept solutions end in
    /// the warm-up) without lowering their cost (`bench/peers/README.md`, "The polish").
    pub portfolio_polish: bool,
    /// [`WarmUp::Portfolio`]: where the first two starts agree (not apart,
    /// [`Settings::portfolio_apart`]) on a cost above this factor times the cost the
    /// augmented-Lagrangian start had after its first inner solve (zero multipliers, the initial
    /// penalty: a relaxation in which the path may still cut through the obstacles), the third
    /// start still runs its barrier homotopy, and goes on only when it then passes some obstacle
    /// on another side than the kept solution (the unit gradient of a state row at its most
    /// active state more than 90 degrees from the kept solution's). Two starts that agree can
    /// share a poor optimum, which only another way around the obstacles escapes; a third start
    /// on the same sides mostly ends in the same optimum. With the default `Some(1.2)` the
    /// family replays of ten seeds match the peers' best 11 times more (of 2100) and end more
    /// than 5 % above it 12 times fewer, for about 1.02x the time (`bench/peers/README.md`,
    /// "Another side where the starts agree"). `None`: no third start where the first two agree.
    pub portfolio_new_side: Option<f64>,
    /// [`WarmUp::Portfolio`]: threads of a cold solve, 1 or 2. With 2 the first two starts (the
    /// augmented Lagrangian's and the barrier's) run at once, the second on a sibling solver on
    /// another thread, built at the first such solve (it allocates its own workspace then; each
    /// such solve starts a scoped thread); the third start and the polish follow on the calling
    /// thread. The guided starts ([`Settings::portfolio_flip`], [`Settings::portfolio_plan`],
    /// [`Settings::portfolio_mirror`]) then run two at a time on two guide solvers (but the
    /// first planned start, on which the next starts hang), each measured against the solution
    /// kept before the pair ([`Settings::portfolio_abandon`], [`Settings::portfolio_stall`]);
    /// where the first of a pair is kept, the second runs again against the new kept cost, as it
    /// would after it. Every start is the same computation as with 1, so the solution, iterations and
    /// status are too; only the wall time differs (0.80x with the polish on
    /// `bench/peers/family.py` with the first two starts at once; the guided starts in pairs
    /// take the family replays to 0.91x-0.96x of that). 1 (the default): one thread.
    pub portfolio_threads: usize,
    /// [`WarmUp::Portfolio`]: where the kept solution (feasible) costs more than this factor
    /// times the optimum of the problem without its constraints (solved from the kept solution,
    /// or the augmented-Lagrangian start's relaxed path where that costs less; above it by more
    /// than the factor minus one of that cost's magnitude), one more start per
    /// binding state row of the kept solution (a positive multiplier or a zero value somewhere),
    /// steered to the row's far side: an augmented-Lagrangian start from the initial guess with
    /// a guide row (a half-space past the far boundary along the row's gradient, at the time the
    /// row is most active) for [`Settings::portfolio_flip_guide`] iterations, then without it to
    /// its own optimum, kept when better. When every start chose the poor side of a binding
    /// obstacle (a path round a whole cluster, where a cheaper one passes between two), only a
    /// start on the other side escapes. Only with two or more state rows (with one, the other
    /// starts already go round it both ways) and on solves over the problem's whole horizon
    /// (not after [`crate::SafeCddpSolver::set_horizon`] to a shorter one). `None`: no flipped
    /// starts. See `bench/peers/README.md`,
    /// "The other side of each binding obstacle". This gate holds where the portfolio's first two
    /// starts agree; where they end apart, [`Settings::portfolio_flip_apart`]'s.
    pub portfolio_flip: Option<f64>,
    /// [`Settings::portfolio_flip`]: the gate's factor where the portfolio's first two starts
    /// (the augmented Lagrangian's and the barrier's) end apart: either infeasible, or their
    /// costs more than 1e-6 apart relative to the larger (the benchmark's own tolerance for the
    /// same optimum). Two starts that agree have most likely found the problem's way round the
    /// obstacles (P2, P3, about half of the family's problems); where they do not, the kept
    /// solution is one of several optima within reach, and one only a little above the
    /// obstacle-free optimum's cost may still be the poorer. With the default 1.25 (and
    /// [`Settings::portfolio_flip_starts`] 2) the family replays of twelve seeds match the
    /// peers' best on 2433 of 2520 problems instead of 2414 (1.5 everywhere, every binding row),
    /// and end more than 5 % above it on 11 instead of 23, none worse than before, for 1.04x the
    /// iterations (`bench/peers/README.md`, "Which problems get the flipped starts"). Finite and
    /// at least 1.
    pub portfolio_flip_apart: f64,
    /// [`Settings::portfolio_flip`]: at most this many flipped starts, for the binding rows in
    /// order (largest summed multiplier first; a row with no far side is passed over). Each is
    /// a whole solve from the initial guess. On the family replays of twelve seeds a third one
    /// found no better optimum where the first two had not, for 2 % more iterations; with 1,
    /// nine problems end higher than with one start per binding row (one 145 % above the peers'
    /// optimum instead of matching it), none with 2. At least 1.
    pub portfolio_flip_starts: usize,
    /// [`Settings::portfolio_flip`]: the iterations a flipped start keeps its guide row.
    pub portfolio_flip_guide: usize,
    /// [`Settings::portfolio_flip`]: after the flipped starts (behind the same gate), one more
    /// start steered to the far side of every state row at once, each at its own most active
    /// time on the kept solution (the guide's targets as a flipped start's, all in one guide
    /// row), for this many iterations, then without them to its own optimum, kept when better:
    /// the way round the other side of a whole cluster of obstacles, which no start flipping one
    /// obstacle reaches (on `point-s1-i21-a0` the kept path passes all four obstacles on one side,
    /// 35 % above the peers' optimum, which passes all four on the other, and the flipped start
    /// of the one that binds ends 126 % above it). Only where two or more rows have a far side
    /// at distinct times, all of one relative degree. With the default `Some(5)` the
    /// family replays of ten seeds match the peers' best on 1995 of 2100 problems instead of
    /// 1969, and end more than 5 % above it on 21 instead of 32, for 1.06x the time
    /// (`bench/peers/README.md`, "The other side of a whole cluster"). `None`: no such start.
    pub portfolio_mirror: Option<usize>,
    /// [`Settings::portfolio_flip`]: before the flipped starts (behind the same gate), one more
    /// start steered round the obstacles on the sides of the shortest path of the robot's
    /// position among them ([`crate::plan::shortest_path`], from the initial state to where the
    /// gate's obstacle-free solve ends), where the kept solution passes one of the obstacles that
    /// path wraps round on the other side: one target per such obstacle, a half-plane just
    /// outside it at the path's contact, at the time the path reaches it at a steady speed, for
    /// this many iterations, then without them to its own optimum, kept when better. Where it is
    /// not kept, a second start steered the same way from the kept solution's controls instead
    /// of the initial guess (a car that heads for the path's side from rest may end far above
    /// the kept cost). Every start before them picks its sides on the way in, near its initial
    /// guess; the shortest path's sides are the peers' optimum's on 14 of the 25 problems of the
    /// family replays of 18 seeds where ddpkit ended more than 5 % above it. A flipped start to
    /// the far side of an obstacle these starts already steer to the other side is left out (the
    /// next binding row's takes its place), and where the first is kept the mirrored start is
    /// left out. With the default `Some(5)` the replays of seeds 1-12 match the peers' best on
    /// 2444 of 2520 problems instead of 2438 and end more than 5 % above it on 8 instead of 11,
    /// seeds 13-18 (never tuned on) on 1214 of 1260 instead of 1205 and 6 instead of 14, for
    /// 1.02x-1.03x the iterations and about 1.00x the time per problem (`bench/peers/README.md`,
    /// "The planned start"). Only where the state constraints include discs
    /// ([`crate::Constraint::planar_disc`]), all on the same two state entries and of one
    /// relative degree. `None`: no such starts.
    pub portfolio_plan: Option<usize>,
    /// [`WarmUp::Portfolio`]: a start from the initial guess after the first two (the third
    /// start, each flipped start) stops, discarded ([`StartOutcome::Stalled`]), once this many
    /// accepted full steps in a row of its augmented Lagrangian, at a feasible trajectory,
    /// lowered its cost so little that at that rate it could not come down to the kept
    /// solution's cost within its remaining iterations. Such a start crawls along the
    /// obstacles' edges to the iteration limit: on the family replays of ten seeds (at
    /// `family.py`'s 500 iterations) it stopped starts on 54 problems, up to 1595 of one
    /// problem's 2463 iterations, 2.7 % of all, and changed no outcome (`bench/peers/README.md`,
    /// "Stalled starts"). The second start is left out, as it may run alongside the first
    /// ([`Settings::portfolio_threads`]) before the cost to beat is known, and the result must
    /// not depend on the thread count; so is the polish, which goes on from the kept solution
    /// and first rises above its cost (at 200 iterations one polish was stopped that would have
    /// come down below it). `0`: none stop.
    pub portfolio_stall: usize,
    /// [`WarmUp::Portfolio`]: a flipped, a planned or the mirrored start
    /// ([`Settings::portfolio_flip`], [`Settings::portfolio_plan`],
    /// [`Settings::portfolio_mirror`]) stops, discarded ([`StartOutcome::Abandoned`]), once it
    /// is past [`Settings::portfolio_abandon_after`] iterations after its guided ones at a
    /// trajectory, feasible or not, whose cost is more than this fraction above the kept
    /// solution's, and has been for [`Settings::portfolio_abandon_run`] iterations in a row. Its guide has taken it round the other side of an obstacle, and by then what
    /// is left to it are mostly the small moves of a path that already clears them; the guided
    /// starts that find a better optimum end below the kept cost or come near it sooner. The
    /// third start is left out: past its barrier homotopy it may still be feasible at hundreds
    /// of times the kept cost and then come down below it. With the default `Some(0.3)` after 45
    /// iterations the family replays of twelve seeds match the peers on the same 2434 of 2520
    /// problems as without it, for 0.97x the iterations; 10 problems end higher (up to 31 %),
    /// where a guided start would have gone on to an optimum below the peers'. On two seeds not
    /// tuned on every one of 420 problems ends as before (`bench/peers/README.md`, "Abandoned
    /// starts"). Until 2026-12-07 only feasible trajectories were tested; an infeasible one far
    /// above the kept cost has further to go, and testing it too changed no outcome of the
    /// replays of eighteen seeds, for 0.976x the iterations ("Dual bounds"). `None`: none stop.
    pub portfolio_abandon: Option<f64>,
    /// [`Settings::portfolio_abandon`]: the iterations a start runs before the test applies.
    pub portfolio_abandon_after: usize,
    /// [`Settings::portfolio_abandon`]: the iterations in a row a start's cost must stay above
    /// the test's bound before it stops (at least 1). A guided start that leaves an infeasible
    /// stretch for a feasible path jumps far above the kept cost and then falls fast:
    /// `unicycle-s17-i1-a0`'s second flipped start, stopped at 21x the kept cost by a test of the
    /// single iteration, runs on to 1.5675, below the peers' 1.5711 and the kept 2.34, in 64 more
    /// iterations. With the default 20 the family replays of eighteen seeds end as with 1 but
    /// there (a miss of 49 % becomes a match) and on one problem 0.1 % lower, for 1.002x the
    /// iterations; 10 keeps the miss (`bench/peers/README.md`, "A guided start's jump to
    /// feasibility").
    pub portfolio_abandon_run: usize,
    /// [`WarmUp::Portfolio`]: a guided or the third start ([`Settings::portfolio_flip`],
    /// [`Settings::portfolio_plan`], [`Settings::portfolio_mirror`],
    /// [`Settings::portfolio_third_mu`]) stops, discarded ([`StartOutcome::Abandoned`]), at the
    /// end of an inner solve of its augmented Lagrangian that converged (to
    /// `al_inner_tolerance` or the gradient test) where the dual bound, the Lagrangian
    /// `J + lambda^T g~` with the updated multipliers, is more than this fraction above the kept
    /// solution's cost. The trajectory then minimises the Lagrangian, whose value bounds from
    /// below the cost of every feasible trajectory near it (the dual function of the local
    /// problem, as in the augmented-Lagrangian methods' duality: Bertsekas 1982): the start is
    /// headed for an optimum above the kept one, however far its own cost still is from it.
    /// Inner solves that end on the coarser `al_inner_progress` are not minimisers, and tested
    /// there the bound stopped starts that went on to better optima. With the default
    /// `Some(0.01)` the family replays of eighteen seeds end as without it (and without
    /// [`Settings::portfolio_abandon`]'s test of infeasible trajectories) for 0.95x the
    /// iterations (`bench/peers/README.md`, "Dual bounds"). `None`: no such test.
    pub portfolio_dual_bound: Option<f64>,
    /// Initial `rho` of the warm-up.
    pub al_rho_init: f64,
    /// Factor on `rho` when the violation did not fall to a quarter.
    pub al_rho_factor: f64,
    /// Largest `rho`.
    pub al_rho_max: f64,
    /// Largest violation at which the warm-up hands over to the KKT/QP iterations.
    pub al_switch_violation: f64,
    /// In a cold solve with a warm-up, the shortest step the KKT/QP iterations' line search
    /// tries (at least `line_search.step_min`); when no longer step is accepted the step has
    /// failed, and the warm-up takes over and runs to its own convergence, as after any failed
    /// KKT/QP step. Each trial of the KKT/QP line search solves a QP at every knot, and short
    /// steps there mean that the per-step QPs are blocked (a row the working set left out, a
    /// state row the controls move only by `O(dt^r)`): on P3 the augmented-Lagrangian start
    /// crept on for six steps of 1/8 to 1/512 and then failed anyway. With the default `0.25`
    /// the family replays of ten seeds take 0.92x the time for the same matches (1966 of 2100
    /// instead of 1965), P3's portfolio 0.76x and P2's 0.93x (`bench/peers/README.md`, "Short
    /// KKT/QP steps"). Warm starts (an MPC step, a re-solve) keep the line search's own
    /// `step_min`: there the short steps are the way on (with the floor on every solve, Table
    /// I's open-loop car reached its goal in 18 of 100 episodes instead of 98). `0`:
    /// `line_search.step_min`.
    pub kkt_step_min: f64,
    /// Relative merit change below which an inner warm-up solve counts as done (multiplier update).
    pub al_inner_tolerance: f64,
    /// An inner augmented-Lagrangian solve also counts as done after a full step (`alpha = 1`)
    /// that changed the merit by less than `al_inner_progress * rho * v^2`, `v` the largest
    /// violation: the inner solve has then done its part, since the next multiplier update
    /// moves the merit by about `rho v^2` (the penalty of the remaining violation), and further
    /// inner steps refine a minimiser the update is about to move. The inner solves are then as
    /// inexact as the outer iteration allows, as in the augmented-Lagrangian methods whose
    /// inner tolerance follows the constraint violation (Conn, Gould and Toint 1991). It applies
    /// to the warm-up of a cold start and to re-entries after a failed KKT/QP step, not to the
    /// re-entries after a tightening in an MPC loop, whose few iterations per step fare better
    /// with patient inner solves (as for `al_inner_iterations`; with the rule there too, the
    /// quadrotor of Table I reached its goal in 3-4 fewer of 100 episodes per row). With the
    /// defaults (1, below a violation of 0.1), the family replays of nine seeds (two generated
    /// to check the choice) match the peers' best on 1739 of 1890 problems instead of 1738, 70
    /// miss by more than 5 % instead of 72, for 0.81x the iterations and 0.91x the time
    /// (geometric mean of interleaved solves; `bench/peers/README.md`, "The inner solves'
    /// tolerance"). 0: only `al_inner_tolerance` and the iteration limits end an inner solve.
    pub al_inner_progress: f64,
    /// [`Settings::al_inner_progress`] applies once the largest violation is below this (in
    /// the rows' own units). Further out the inner solves still choose the way around the
    /// obstacles, and a multiplier update after every step would push each knot out of the
    /// nearest side (P3 started from its unconstrained optimum, through the obstacles, ends
    /// 3.7x above the optimum with the rule applied at any violation, at the optimum with it
    /// below 0.1). Infinite: at any violation.
    pub al_inner_progress_below: f64,
    /// Once the augmented Lagrangian's penalty `rho` has reached [`Settings::al_near_rho`],
    /// rows inactive at the nominal trajectory (`lambda + rho g <= 0`) but within this margin
    /// of their boundary (`g > -al_near_margin`, in the rows' own units) get the penalty's
    /// Gauss-Newton curvature `rho g_x g_x^T` in the backward pass, without a gradient. At such
    /// a penalty the row turns on within a tiny step, and a model blind to it promises a
    /// decrease that the merit, rising as `rho (g_x dx)^2`, does not give: the line searches
    /// then fail down to the shortest step (23 % of the forward passes on a family seed's
    /// replay, most of them in a handful of slow problems). With the curvature the step stays
    /// on the row's side, a generalised Hessian of the penalty's `max(0, .)^2` at its kink. The
    /// default `1e-4` (from `rho = 1e7`): on the family replays of nine seeds 1747 of 1890
    /// problems match the peers' best instead of 1739, 64 miss by more than 5 % instead of 70
    /// (`bench/peers/README.md`, "Rows near their boundary"). Like
    /// [`Settings::al_inner_progress`] it applies to cold starts and to re-entries after a failed
    /// KKT/QP step, not to the MPC's re-entries after a tightening (there it moved the car of
    /// Table I at `beta = 0.99` from 0 to 1 violated episode). 0: none.
    pub al_near_margin: f64,
    /// The penalty from which [`Settings::al_near_margin`] applies. At lower penalties the
    /// switching region is wide enough for the line search, and the extra curvature only slows
    /// the inner solves (at every penalty: 12 fewer matches on seven seeds).
    pub al_near_rho: f64,
    /// [`Settings::al_near_margin`]'s curvature is turned off for the rest of a solve once this
    /// many accepted full steps in a row of the augmented Lagrangian, at a feasible trajectory,
    /// each changed the merit by less than [`Settings::al_near_crawl_change`] (relative). The
    /// curvature can hold a row just inside its boundary with no multiplier (the update
    /// `lambda + rho g~` stays negative at a slack of `4e-5` and `rho = 1e7`) while the cost pulls
    /// into it: the steps then lower the cost by about `1e-6` relative each, to the iteration
    /// limit (`car-s1-i40-a0`'s barrier start: 494 iterations). Without the curvature the next
    /// step crosses the row, the update gives it a multiplier and the inner solves converge
    /// (100 iterations there). With the default 5 (and `1e-5`) the family replays of twelve
    /// seeds match the peers' best on 2437 of 2520 problems instead of 2435, miss by more than
    /// 5 % on the same 11, for 0.97x the iterations; the problems of more than 500 iterations
    /// take 0.85x theirs (`bench/peers/README.md`, "Crawls along rows held off their
    /// boundary"). `0`: never.
    pub al_near_crawl: usize,
    /// [`Settings::al_near_crawl`]: the relative merit change below which a full step crawls.
    pub al_near_crawl_change: f64,
    /// Most accepted inner iterations between two multiplier updates of the warm-up: the inner
    /// solves are inexact, and on a long obstacle-hugging valley (the car) waiting for
    /// `al_inner_tolerance` can take a hundred iterations of little progress.
    pub al_inner_iterations: usize,
    /// The same for the warm-up of a cold start (zero multipliers, no solution nearby): more
    /// frequent multiplier updates halve its iterations on `bench/peers/family.py` at the same
    /// optima, whereas re-entries after a tightening in an MPC loop, with few iterations per
    /// step, fare better with the patient `al_inner_iterations` (the penalty rises at each
    /// update that does not cut the violation to a quarter).
    pub al_cold_inner_iterations: usize,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            method: Method::Ilqr,
            max_iterations: 200,
            // The projected gradient a tenth of ddp-core's test (Crocoddyl's `th_stop`), the
            // merit change tighter than ddp-core's, as the KKT/QP iterations converge fast near
            // the optimum. A gradient test of 1e-12 (the default until 2026-12-06) ran the inner
            // solves of the augmented Lagrangian and the last KKT/QP steps on to `|Q_u|` of
            // 1e-6, far below what the cost resolves: on the family replays of twelve seeds it
            // matched the peers on 2405 of 2520 problems against 2414 now, for 1.02x the
            // iterations. At ddp-core's 1e-9 (2416) a solve can stop 1.6e-6 (relative) above
            // its optimum, the cost's error growing as `|Q_u|^2` (`bench/peers/README.md`,
            // "The gradient test").
            tolerances: Tolerances {
                gradient: 1e-10,
                cost: 1e-12,
            },
            constraint_tolerance: 1e-8,
            active_threshold: 1e-6,
            regularization: RegularizationSettings::default(),
            line_search: LineSearchSettings::default(),
            merit_penalty: 1e3,
            trust_region: f64::INFINITY,
            trust_shrink: 0.5,
            max_qp_retries: 2,
            elastic: true,
            qp_method: QpMethod::Fast,
            constraint_hessian: false,
            max_relative_degree: 4,
            warm_up: WarmUp::Portfolio,
            // A soft barrier: three subproblems of at most 10 iterations from `mu = 3e-2`, the
            // logarithm continued as a quadratic below a slack of 0.1, so that the trajectory
            // may cross an obstacle's edge while it chooses its way around, as IPOPT's slacks
            // let its iterates do (chosen on the family replays of six seeds, checked on a
            // seventh: `bench/peers/README.md`, "The soft barrier").
            barrier_mu_init: 3e-2,
            barrier_mu_factor: 0.2,
            barrier_mu_final: 1e-3,
            barrier_relaxation: 1e-1,
            barrier_inner_iterations: 10,
            barrier_funnel: 3e-2,
            portfolio_third_mu: Some(3e-3),
            portfolio_apart: 1e-3,
            portfolio_polish: true,
            portfolio_new_side: Some(1.2),
            portfolio_threads: 1,
            portfolio_flip: Some(1.5),
            portfolio_flip_apart: 1.25,
            portfolio_flip_starts: 2,
            portfolio_flip_guide: 25,
            portfolio_mirror: Some(5),
            portfolio_plan: Some(5),
            portfolio_stall: 10,
            portfolio_abandon: Some(0.3),
            portfolio_abandon_after: 45,
            portfolio_abandon_run: 20,
            portfolio_dual_bound: Some(0.01),
            al_rho_init: 10.0,
            al_rho_factor: 10.0,
            al_rho_max: 1e8,
            al_switch_violation: 1e-8,
            kkt_step_min: 0.25,
            al_inner_tolerance: 1e-7,
            al_inner_progress: 1.0,
            al_inner_progress_below: 0.1,
            al_near_margin: 1e-4,
            al_near_rho: 1e7,
            al_near_crawl: 5,
            al_near_crawl_change: 1e-5,
            al_inner_iterations: 20,
            al_cold_inner_iterations: 5,
        }
    }
}

impl Settings {
    /// Whether a guided start is tested against the kept solution's cost
    /// ([`Settings::portfolio_stall`], [`Settings::portfolio_abandon`],
    /// [`Settings::portfolio_dual_bound`]).
    pub(crate) fn tests_later_starts(&self) -> bool {
        self.portfolio_stall > 0 || self.portfolio_abandon.is_some() || self.portfolio_dual_bound.is_some()
    }

    /// Rejects settings that cannot work, naming the field.
    pub fn validate(&self) -> Result<()> {
        let check = |name: &str, ok: bool, v: f64, what: &str| {
            if ok {
                Ok(())
            } else {
                Err(Error::invalid(
                    format!("settings.{name}"),
                    format!("must be {what}, got {v}"),
                ))
            }
        };
        let finite_nonneg = |v: f64| v.is_finite() && v >= 0.0;
        let finite_pos = |v: f64| v.is_finite() && v > 0.0;
        if self.max_iterations == 0 {
            return Err(Error::invalid("settings.max_iterations", "must be at least 1"));
        }
        if self.al_inner_iterations == 0 {
            return Err(Error::invalid("settings.al_inner_iterations", "must be at least 1"));
        }
        if self.al_cold_inner_iterations == 0 {
            return Err(Error::invalid(
                "settings.al_cold_inner_iterations",
                "must be at least 1",
            ));
        }
        if self.barrier_inner_iterations == 0 {
            return Err(Error::invalid(
                "settings.barrier_inner_iterations",
                "must be at least 1",
            ));
        }
        if self.max_relative_degree == 0 {
            return Err(Error::invalid("settings.max_relative_degree", "must be at least 1"));
        }
        self.tolerances.validate()?;
        self.regularization.validate()?;
        self.line_search.validate()?;
        check(
            "constraint_tolerance",
            finite_nonneg(self.constraint_tolerance),
            self.constraint_tolerance,
            "finite and >= 0",
        )?;
        check(
            "active_threshold",
            finite_nonneg(self.active_threshold),
            self.active_threshold,
            "finite and >= 0",
        )?;
        check(
            "merit_penalty",
            finite_nonneg(self.merit_penalty),
            self.merit_penalty,
            "finite and >= 0",
        )?;
        check(
            "trust_region",
            self.trust_region > 0.0,
            self.trust_region,
            "> 0 (infinite for none)",
        )?;
        check(
            "al_rho_init",
            finite_pos(self.al_rho_init),
            self.al_rho_init,
            "finite and > 0",
        )?;
        check(
            "al_rho_factor",
            self.al_rho_factor.is_finite() && self.al_rho_factor >= 1.0,
            self.al_rho_factor,
            ">= 1",
        )?;
        check(
            "al_rho_max",
            finite_pos(self.al_rho_max) && self.al_rho_max >= self.al_rho_init,
            self.al_rho_max,
            ">= al_rho_init",
        )?;
        check(
            "al_switch_violation",
            finite_nonneg(self.al_switch_violation),
            self.al_switch_violation,
            "finite and >= 0",
        )?;
        check(
            "al_inner_tolerance",
            finite_nonneg(self.al_inner_tolerance),
            self.al_inner_tolerance,
            "finite and >= 0",
        )?;
        check(
            "al_inner_progress",
            finite_nonneg(self.al_inner_progress),
            self.al_inner_progress,
            "finite and >= 0",
        )?;
        check(
            "al_inner_progress_below",
            self.al_inner_progress_below >= 0.0,
            self.al_inner_progress_below,
            ">= 0 (infinite: at any violation)",
        )?;
        check(
            "al_near_margin",
            finite_nonneg(self.al_near_margin),
            self.al_near_margin,
            "finite and >= 0",
        )?;
        check(
            "al_near_rho",
            finite_pos(self.al_near_rho),
            self.al_near_rho,
            "finite and > 0",
        )?;
        check(
            "al_near_crawl_change",
            finite_nonneg(self.al_near_crawl_change),
            self.al_near_crawl_change,
            "finite and >= 0",
        )?;
        check(
            "barrier_mu_init",
            finite_pos(self.barrier_mu_init),
            self.barrier_mu_init,
            "finite and > 0",
        )?;
        check(
            "barrier_mu_factor",
            self.barrier_mu_factor > 0.0 && self.barrier_mu_factor < 1.0,
            self.barrier_mu_factor,
            "in (0, 1)",
        )?;
        check(
            "barrier_mu_final",
            finite_pos(self.barrier_mu_final) && self.barrier_mu_final <= self.barrier_mu_init,
            self.barrier_mu_final,
            "finite, > 0 and <= barrier_mu_init",
        )?;
        check(
            "barrier_funnel",
            self.barrier_funnel > 0.0,
            self.barrier_funnel,
            "> 0 (f64::INFINITY: no limit)",
        )?;
        check(
            "portfolio_apart",
            finite_nonneg(self.portfolio_apart),
            self.portfolio_apart,
            "finite and >= 0",
        )?;
        if let Some(mu) = self.portfolio_third_mu {
            check("portfolio_third_mu", finite_pos(mu), mu, "finite and > 0")?;
        }
        if let Some(factor) = self.portfolio_new_side {
            check("portfolio_new_side", finite_pos(factor), factor, "finite and > 0")?;
        }
        if let Some(factor) = self.portfolio_flip {
            check(
                "portfolio_flip",
                factor.is_finite() && factor >= 1.0,
                factor,
                "finite and >= 1",
            )?;
        }
        check(
            "kkt_step_min",
            (0.0..=1.0).contains(&self.kkt_step_min),
            self.kkt_step_min,
            "in [0, 1]",
        )?;
        check(
            "portfolio_flip_apart",
            self.portfolio_flip_apart.is_finite() && self.portfolio_flip_apart >= 1.0,
            self.portfolio_flip_apart,
            "finite and >= 1",
        )?;
        if self.portfolio_flip_starts == 0 {
            return Err(Error::invalid(
                "settings.portfolio_flip_starts",
                "must be at least 1 (portfolio_flip = None: no flipped starts)",
            ));
        }
        if let Some(fraction) = self.portfolio_abandon {
            check(
                "portfolio_abandon",
                finite_nonneg(fraction),
                fraction,
                "finite and >= 0",
            )?;
        }
        if let Some(fraction) = self.portfolio_dual_bound {
            check(
                "portfolio_dual_bound",
                finite_nonneg(fraction),
                fraction,
                "finite and >= 0",
            )?;
        }
        if self.portfolio_flip_guide == 0 {
            return Err(Error::invalid("settings.portfolio_flip_guide", "must be at least 1"));
        }
        if self.portfolio_abandon_run == 0 {
            return Err(Error::invalid("settings.portfolio_abandon_run", "must be at least 1"));
        }
        if self.portfolio_plan == Some(0) {
            return Err(Error::invalid(
                "settings.portfolio_plan",
                "must be at least 1 iteration (None: no planned start)",
            ));
        }
        if self.portfolio_mirror == Some(0) {
            return Err(Error::invalid(
                "settings.portfolio_mirror",
                "must be at least 1 iteration (None: no mirrored start)",
            ));
        }
        check(
            "barrier_relaxation",
            finite_pos(self.barrier_relaxation),
            self.barrier_relaxation,
            "finite and > 0",
        )?;
        check(
            "trust_shrink",
            self.trust_shrink > 0.0 && self.trust_shrink < 1.0,
            self.trust_shrink,
            "in (0, 1)",
        )?;
        if !(1..=2).contains(&self.portfolio_threads) {
            return Err(Error::invalid(
                "settings.portfolio_threads",
                format!("must be 1 or 2, got {}", self.portfolio_threads),
            ));
        }
        Ok(())
    }
}

/// How a solve (or an iteration) ended. Bad input is an [`Error`], never a status.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// A stopping test was met on a feasible trajectory.
    Converged,
    /// `max_iterations` reached; the trajectory is the best found.
    MaxIterations,
    /// `Q_uu` could not be made positive definite below `mu_max`.
    RegularizationLimit,
    /// No step length decreased the merit, even at `mu_max`.
    LineSearchFailed,
    /// The QP of knot `knot` stayed infeasible through the retries and the regularisation, or the
    /// final trajectory violates a (tightened) constraint first at knot `knot`.
    Infeasible {
        /// The knot whose QP (or constraint) failed.
        knot: usize,
    },
    /// Clarabel failed (neither a solution nor an infeasibility certificate) at `knot`.
    QpFailed {
        /// The knot whose QP failed.
        knot: usize,
    },
    /// The initial rollout or its cost was not finite.
    NumericalError,
}

impl Status {
    /// Short lower-case name (`"converged"`, `"infeasible"`, ...).
    pub fn as_str(&self) -> &'static str {
        match self {
            Status::Converged => "converged",
            Status::MaxIterations => "max_iterations",
            Status::RegularizationLimit => "regularization_limit",
            Status::LineSearchFailed => "line_search_failed",
            Status::Infeasible { .. } => "infeasible",
            Status::QpFailed { .. } => "qp_failed",
            Status::NumericalError => "numerical_error",
        }
    }
}

/// One row of the iteration log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IterationLog {
    /// Iteration number (0 is the initial rollout).
    pub iteration: usize,
    /// Cost `J` after this iteration.
    pub cost: f64,
    /// Largest violation of a tightened row after this iteration.
    pub violation: f64,
    /// Projected gradient of the backward pass.
    pub gradient: f64,
    /// Accepted step length (0 when rejected).
    pub step: f64,
    /// Regularisation of the backward pass.
    pub mu: f64,
    /// Rows in the backward pass's working sets, summed over the knots.
    pub active: usize,
    /// Whether the step was accepted.
    pub accepted: bool,
    /// Whether the constraints were tightened after this iteration.
    pub tightened: bool,
    /// The warm-up phase this iteration belonged to ([`Settings::warm_up`]; `None`: the KKT/QP
    /// iterations).
    pub warm_up: Option<WarmUp>,
}

/// How one start of a [`WarmUp::Portfolio`] solve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StartOutcome {
    /// Its solution is the solve's.
    Kept,
    /// Its solution was kept until the polish ([`Settings::portfolio_polish`]) went on from it
    /// to a better one: the polish's entry is [`StartOutcome::Kept`], and the report's
    /// `iterations` count both.
    Polished,
    /// It ran to its end, and another start's solution was kept.
    Discarded,
    /// It stopped at the end of its homotopy on the kept solution's sides
    /// ([`Settings::portfolio_new_side`]).
    SameSide,
    /// It stopped where, at the rate its cost was falling, it could not reach the kept
    /// solution's cost within its iterations ([`Settings::portfolio_stall`]).
    Stalled,
    /// It stopped at a feasible trajectory well above the kept solution's cost
    /// ([`Settings::portfolio_abandon`]).
    Abandoned,
}

impl StartOutcome {
    /// `"kept"`, `"polished"`, `"discarded"`, `"same_side"`, `"stalled"` or `"abandoned"`.
    pub fn as_str(&self) -> &'static str {
        match self {
            StartOutcome::Kept => "kept",
            StartOutcome::Polished => "polished",
            StartOutcome::Discarded => "discarded",
            StartOutcome::SameSide => "same_side",
            StartOutcome::Stalled => "stalled",
            StartOutcome::Abandoned => "abandoned",
        }
    }
}

/// One start of a [`WarmUp::Portfolio`] solve: which it was, how far it went and whether its
/// solution was kept. The starts' iterations add up to the report's `iterations` (the
/// [`StartOutcome::Kept`] and [`StartOutcome::Polished`] ones) plus its `discarded_iterations`
/// (the others).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StartReport {
    /// [`WarmUp::AugmentedLagrangian`] or [`WarmUp::Barrier`] from the initial guess;
    /// [`WarmUp::None`] for the polish (the KKT/QP iterations from the kept solution).
    pub warm_up: WarmUp,
    /// The barrier's initial `mu` where it is not [`Settings::barrier_mu_init`] (the third start,
    /// [`Settings::portfolio_third_mu`]).
    pub barrier_mu_init: Option<f64>,
    /// For a flipped start ([`Settings::portfolio_flip`]): the index of the state constraint
    /// whose other side it was steered to.
    pub flip: Option<usize>,
    /// The mirrored start ([`Settings::portfolio_mirror`]): steered to the other side of every
    /// state row at once.
    pub mirror: bool,
    /// A planned start ([`Settings::portfolio_plan`]): steered round the obstacles on the sides
    /// of the shortest path among them.
    pub plan: bool,
    /// It began from the kept solution's controls rather than the initial guess: the polish, and
    /// the second planned start ([`Settings::portfolio_plan`]).
    pub from_kept: bool,
    /// Accepted steps.
    pub iterations: usize,
    /// Cost where it ended.
    pub cost: f64,
    /// Largest violation of a tightened row where it ended.
    pub max_violation: f64,
    /// How its iterations ended.
    pub status: Status,
    /// Whether its solution was kept.
    pub outcome: StartOutcome,
}

impl StartReport {
    /// `"augmented_lagrangian"`, `"barrier"`, `"barrier (mu_init 3.0e-3)"`, `"polish"`,
    /// `"flip (constraint 2)"`, `"mirror"`, `"plan"` or `"plan (from the kept solution)"`.
    pub fn name(&self) -> String {
        if self.mirror {
            return "mirror".to_string();
        }
        if self.plan {
            let from = if self.from_kept {
                " (from the kept solution)"
            } else {
                ""
            };
            return format!("plan{from}");
        }
        if let Some(j) = self.flip {
            return format!("flip (constraint {j})");
        }
        match (self.warm_up, self.barrier_mu_init) {
            (WarmUp::None, _) => "polish".to_string(),
            (w, Some(mu)) => format!("{} (mu_init {mu:.1e})", w.as_str()),
            (w, None) => w.as_str().to_string(),
        }
    }
}

/// Most starts of one [`WarmUp::Portfolio`] solve besides the flipped ones (two, the third, the
/// polish, the two planned starts and the mirrored start).
pub(crate) const MAX_STARTS: usize = 7;

/// Outcome and statistics of a solve. Lives in the solver; `log` is allocated once.
#[derive(Debug, Clone)]
pub struct Report {
    /// How the solve ended.
    pub status: Status,
    /// Accepted steps.
    pub iterations: usize,
    /// Final cost `J`.
    pub cost: f64,
    /// Cost of the initial rollout.
    pub initial_cost: f64,
    /// Largest violation of an original (untightened) constraint row over the trajectory.
    pub max_violation: f64,
    /// Largest violation of a tightened row.
    pub max_violation_tightened: f64,
    /// Final projected gradient.
    pub gradient: f64,
    /// Final regularisation.
    pub mu: f64,
    /// Backward passes (including regularisation retries).
    pub backward_passes: usize,
    /// Forward passes (line-search trials and QP retries).
    pub forward_passes: usize,
    /// Forward passes abandoned on an infeasible QP.
    pub infeasible_forward_passes: usize,
    /// Constraint tightenings (eqs. 19-20).
    pub tightenings: usize,
    /// QP counters (all forward passes of the solve, every start of a [`WarmUp::Portfolio`]).
    pub qp: QpStats,
    /// Iterations not logged because `log` was full (its capacity is `max_iterations + 1`, at
    /// most [`ddp_core::solver::LOG_PREALLOCATED`]; an MPC that drives
    /// [`crate::SafeCddpSolver::iterate`] by hand may go past it).
    pub log_dropped: usize,
    /// Iterations of the [`WarmUp::Portfolio`] start whose solution was not kept (not in
    /// `iterations` or `log`).
    pub discarded_iterations: usize,
    /// Wall time of the solve (every start of a [`WarmUp::Portfolio`]).
    pub solve_time: Duration,
    /// One row per iteration.
    pub log: Vec<IterationLog>,
    /// The starts of a [`WarmUp::Portfolio`] cold solve, in the order they ran (empty
    /// otherwise).
    pub starts: Vec<StartReport>,
}

impl Report {
    pub(crate) fn new(capacity: usize) -> Self {
        Self {
            status: Status::MaxIterations,
            iterations: 0,
            cost: f64::NAN,
            initial_cost: f64::NAN,
            max_violation: f64::NAN,
            max_violation_tightened: f64::NAN,
            gradient: f64::NAN,
            mu: 0.0,
            backward_passes: 0,
            forward_passes: 0,
            infeasible_forward_passes: 0,
            tightenings: 0,
            qp: QpStats::default(),
            log_dropped: 0,
            discarded_iterations: 0,
            solve_time: Duration::ZERO,
            log: Vec::with_capacity(capacity),
            starts: Vec::with_capacity(MAX_STARTS),
        }
    }

    /// The iteration table without timings (deterministic: for golden logs).
    pub fn table(&self) -> String {
        let mut s = String::from("iter        cost   violation    gradient    step          mu  active\n");
        for r in &self.log {
            s.push_str(&format!(
                "{:4} {:.9e} {:.3e} {:.3e} {:7.4} {:.3e} {:6}{}{}{}\n",
                r.iteration,
                r.cost,
                r.violation,
                r.gradient,
                r.step,
                r.mu,
                r.active,
                if r.accepted || r.iteration == 0 {
                    ""
                } else {
                    "  rejected"
                },
                if r.tightened { "  tightened" } else { "" },
                match r.warm_up {
                    Some(WarmUp::Barrier) => "  barrier",
                    Some(_) => "  al",
                    None => "",
                },
            ));
        }
        if self.log_dropped > 0 {
            s.push_str(&format!("({} more iterations not logged)\n", self.log_dropped));
        }
        s.push_str(&format!(
            "status: {}, iterations: {}, cost: {:.12e}, max violation: {:.3e}\n",
            self.status.as_str(),
            self.iterations,
            self.cost,
            self.max_violation
        ));
        for (i, st) in self.starts.iter().enumerate() {
            s.push_str(&format!(
                "start {}: {}, {} iterations, cost {:.9e}, violation {:.3e}, {}: {}\n",
                i + 1,
                st.name(),
                st.iterations,
                st.cost,
                st.max_violation,
                st.status.as_str(),
                st.outcome.as_str()
            ));
        }
        s
    }
}

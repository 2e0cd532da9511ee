!> Solves of csc_t matrices for the time schemes. Direct (the default): symmetric
!> positive definite matrices with CHOLMOD's LDL^T (simplicial or supernodal; about half the factor
!> entries and half the solve time of an LU), anything else with UMFPACK's LU.
!> Iterative (ls_configure kind 'cg', or 'auto' where ls_auto_kind's cost model, on the
!> symbolic analysis, says so): preconditioned conjugate gradients (module pcg: SSOR by
!> node blocks for one right-hand side, block Jacobi for several), for symmetric
!> positive definite matrices only.
!>
!> ls_factor tries LDL^T when the matrix is symmetric (to SYM_RTOL) and falls back to
!> UMFPACK when it is not, or when LDL^T meets a zero, negative or non-finite pivot
!> (an indefinite J0 = M + c K_theta, e.g. small gamma0 with Nitsche theta = 1: the
!> schemes need an exact solve, so this is not an error). With kind 'cg' a matrix that
!> is not symmetric, or has a diagonal entry <= 0, is factorized directly instead; a CG
!> solve that meets a curvature p^T A p <= 0 (not positive definite) factorizes the
!> matrix directly then and solves again. Either way f%note says so, and f%backend
!> records which one holds the factors. A factor_t owns C pointers: never copy one by
!> assignment.
!>
!> A matrix kept as values on another's pattern (J0 = M + c K_theta on the model's, which
!> M, K and K_theta share) is passed as that csc_t and `val`: ls_factor, ls_solve and
!> ls_solve_many then read a's pattern and val, never a%val, and hold no copy of either
!> (pass the same val to the solves as to ls_factor).
module linear_solver
    use iso_c_binding, only: c_long
    use kinds, only: dp, i8
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_NUMERIC, raise
    use text, only: fixed_text, int_text
    use sparse, only: csc_t, csc_find
    use umfpack, only: lu_t, lu_factor, lu_solve, lu_solve_many, lu_free
    use cholmod, only: cholmod_t, chol_factor, chol_analyse, chol_solve, chol_solve_many, &
                       chol_free, chol_kernel, chol_ordering
    use pcg, only: pcg_t, pcg_setup, pcg_solve, pcg_solve_many, pcg_free
    use ldl_solves, only: pair_ldl_threads, triple_ldl_threads, ldl_threads_env, &
                          ldl_threads_choice, ldl_cpus
    implicit none
    private

    !> Asymmetry accepted as assembly round-off: |a_ij - a_ji| <= SYM_RTOL s_ij with
    !> s_ij = max(|a_ij| + |a_ji|, sqrt(|a_ii a_jj|)) (the pair's own size, or the
    !> diagonal scale that bounds it in an SPD matrix, for entries that nearly cancel).
    !> LDL^T then reads the upper triangle. The h = 0.01 seed J0 has 7e-20; a
    !> non-symmetric Nitsche term (theta /= 1) is many orders larger.
    real(dp), parameter, public :: SYM_RTOL = 1.0e-14_dp

    character(len=*), parameter, public :: BACKEND_CHOLMOD = 'cholmod_ldlt'  !! LDL^T ran
    character(len=*), parameter, public :: BACKEND_UMFPACK = 'umfpack_lu'    !! LU ran
    character(len=*), parameter, public :: BACKEND_PCG = 'pcg'        !! CG ran

    !> Kind 'auto' compares the costs of one solve, estimated from the symbolic analysis
    !> (no numerical factorization): the direct solve sweeps the factor twice, 2 F (F its
    !> entries, D and L); a CG iteration is one product with J0 and two SSOR sweeps of
    !> about one product's cost, 2 nnz(J0), and the step's solve takes AUTO_CG_ITS(dim)
    !> iterations (SSOR: 7.3-8.1 measured on the strip, 9-10 on the box; nearly constant
    !> with the size). CG runs when its estimate is below AUTO_CG_MARGIN(dim) times the
    !> direct one: its nnz(J0) < AUTO_CG_MARGIN(dim) F. 2D, calibrated on the scaling
    !> sweep (docs/performance.md, "Direct and CG on the strip, the disk and the 3D box"):
    !> every measured point where CG's step was faster has its nnz / F <= 1.66 (disk
    !> 47 392 dofs), every one where it was slower >= 2.10 (disk 12 036, CG 0.91x there:
    !> near even; 1.2x and 1.6x slower in scaling_threads.csv) or 2.19 (strip 515 200, CG
    !> 2.8x slower); 1.9 lies between (geometric middle of 1.66 and 2.19). The margin is
    !> above 1 because a factor entry costs more than a J0 entry once the factor leaves
    !> the caches, and the contact correction's columns are solved by CG on their small
    !> supports (the disk). 3D (node triples), on the box swept again since its direct
    !> step became 2.8x faster (docs/scaling/solvers/scaling_box.csv, two runs in
    !> alternation at load average 2.0-2.7): CG's step 1.47x and 1.55x slower at
    !> 19 440 dofs (ratio 1.59), 0.63x and 0.59x at 36 300 (1.23); 1.4 is their geometric
    !> middle (the first sweep's box rows, CG 0.64x at 19 440, predate the faster direct
    !> step). By the model (log-linear between measured sizes) the box crosses
    !> near 26 000 dofs (the steps' measured ratio crossed 1 near 26 000), the disk near
    !> 22 000 (measured: near 11 000 in the first sweep, between 12 036 and 47 392 in
    !> scaling_threads.csv), the strip not up to 515 200 (near 1.6 million by
    !> extrapolation). 1D: direct (not measured; small).
    integer, parameter, public :: AUTO_CG_ITS(3) = [0, 8, 10]
    real(dp), parameter, public :: AUTO_CG_MARGIN(3) = [0.0_dp, 1.9_dp, 1.4_dp]
    !> When the direct solve will run on two threads (&solver threads, DYNCONTACT_THREADS,
    !> the CPUs and PAR_MIN_DOFS, as ldl_threads_choice decides for the matrix's size),
    !> its estimate is divided by AUTO_PAR_SPEEDUP (CG runs on one thread): CG runs when
    !> AUTO_CG_ITS(dim) nnz(J0) < AUTO_CG_MARGIN(dim) F / AUTO_PAR_SPEEDUP. The step's gain
    !> from the second thread depends on the J0 solve's share of the step (docs/performance.md,
    !> "Direct and CG on the strip, the disk and the 3D box"): on an idle machine 1.36x on
    !> the disk at 47 392 dofs (a step mostly the contact correction), 2.9x on the box at
    !> 36 300; on the shared machine (load average 2.2-3.9) about 1 for both (the step
    !> 0.88x-1.30x). Any value above 1.14 sends the disk at 47 392 dofs (ratio 1.66, margin
    !> 1.9) to direct, where CG's step is faster even against two idle threads (15.4
    !> against 20.1 ms); 2 would send the box at 36 300 to direct, right only with a free
    !> core. 1 is the value right on a shared machine; a model that counts the contact
    !> correction's share of the step would tell the two apart.
    real(dp), parameter, public :: AUTO_PAR_SPEEDUP = 1.0_dp

    !> Factors of one matrix and the backend that computed them.
    type, public :: factor_t
        character(len=16) :: backend = ''       !! BACKEND_CHOLMOD, _UMFPACK, _PCG, '' (none)
        logical :: symmetric = .false.          !! the last matrix factorized was symmetric
        logical :: fell_back = .false.          !! symmetric, but LDL^T met a bad pivot
        integer :: n = 0                        !! size factorized (0: no factors)
        integer :: factorizations = 0           !! successful factorizations (kept by ls_free)
        type(cholmod_t) :: ch                   !! LDL^T factors
        type(lu_t) :: lu                        !! LU factors
        character(len=8) :: kind = 'direct'     !! requested: 'direct', 'cg' or 'auto'
        integer :: dim = 0                      !! mesh dimension for 'auto' (0: unknown)
        real(dp) :: cg_rtol = 1.0e-12_dp        !! CG relative residual tolerance
        integer :: cg_max_iter = 500            !! CG iteration limit of one solve
        type(pcg_t) :: cg                       !! CG preconditioner, work and counters
        character(len=200) :: note = ''         !! why CG was asked for and did not run
        integer :: auto_n = 0                   !! 'auto': size of the last decision (0: none)
        integer(i8) :: auto_nnz = 0             !! 'auto': nnz(J0) of the last decision
        integer(i8) :: auto_factor_nnz = 0      !! 'auto': the analysis' factor entries
        character(len=8) :: auto_kind = ''      !! 'auto': what it chose ('' before any)
        integer :: auto_threads = 1             !! 'auto': the direct solve's threads it assumed
        integer :: threads = 0                  !! &solver threads: 0 automatic, 1, 2
        integer :: threads_used = 1             !! threads of the triangular solves of the factors
    end type factor_t

    public :: ls_factor, ls_solve, ls_solve_many, ls_free, ls_kernel, ls_factor_info, &
              csc_is_symmetric, ls_configure, ls_cg_counts, ls_auto_kind, ls_factorization, &
              ls_auto_reason, ls_set_threads, ls_threads

contains

    !> Factorize a: LDL^T if symmetric and positive definite, UMFPACK LU otherwise; or,
    !> when the configured kind resolves to 'cg' and a is symmetric with a positive
    !> diagonal, set up conjugate gradients instead (no factors; f%backend BACKEND_PCG).
    !> Errors are those of the LU (STAT_NUMERIC 'singular matrix', STAT_BAD_INPUT for
    !> inconsistent arrays, STAT_INTERNAL); an LDL^T error other than a bad pivot is
    !> returned as is. With `val`, the matrix is a's pattern with the values val (module
    !> header).
    subroutine ls_factor(f, a, stat, errmsg, val)
        type(factor_t), intent(inout) :: f                  !! factors (created or replaced)
        type(csc_t), intent(in) :: a                        !! matrix (its pattern)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), intent(in), optional :: val(:)            !! (a%nnz) values on a's pattern
        character(len=:), allocatable :: kind
        f%backend = ''
        f%n = 0
        f%fell_back = .false.
        f%note = ''
        if (present(val)) then
            if (size(val) /= a%nnz) then
                call raise(stat, errmsg, STAT_BAD_INPUT, 'ls_factor: val does not have nnz entries')
                return
            end if
        end if
        f%symmetric = csc_is_symmetric(a, val)
        if (trim(f%kind) == 'auto') then
            call auto_decide(f, a, stat, errmsg, val)
            if (stat /= STAT_OK) return
            kind = trim(f%auto_kind)
        else
            kind = ls_auto_kind(f%kind, f%dim, int(a%nnz, i8), 0_i8)
        end if
        call pcg_free(f%cg)
        if (kind == 'cg') then
            if (.not. f%symmetric) then
                f%note = 'the matrix is not symmetric: conjugate gradients do not apply; '// &
                         'it was factorized directly'
            else
                call pcg_setup(f%cg, a, f%cg_rtol, f%cg_max_iter, stat, val=val)
                if (stat == STAT_OK) then
                    call chol_free(f%ch)
                    call lu_free(f%lu)
                    f%backend = BACKEND_PCG
                    f%n = a%n
                    return
                end if
                f%note = 'the matrix has a diagonal entry <= 0 (not positive definite): '// &
                         'conjugate gradients do not apply; it was factorized directly'
            end if
        end if
        call direct_factor(f, a, stat, errmsg, val)
    end subroutine ls_factor

    !> Set the threads of the triangular solves of the next factorizations (&solver
    !> threads): 0 automatic (two when the process may run on two CPUs or more and the
    !> factor is large enough), 1, or 2; DYNCONTACT_THREADS overrides it (ldl_solves'
    !> ldl_threads_choice). The node-block solves (ldl_node_pairs, ldl_node_triples) use
    !> two; the other solves one.
    pure subroutine ls_set_threads(f, threads)
        type(factor_t), intent(inout) :: f                  !! solver (before ls_factor)
        integer, intent(in) :: threads                      !! 0, 1 or 2
        f%threads = max(0, min(2, threads))
    end subroutine ls_set_threads

    !> The threads the triangular solves of the current factors use (1 or 2; 1 for
    !> UMFPACK, CG, cholmod_solve2 and without factors).
    pure integer function ls_threads(f) result(threads)
        type(factor_t), intent(in) :: f      !! factors
        threads = 1
        if (f%n >= 1 .and. f%backend == BACKEND_CHOLMOD) threads = f%threads_used
    end function ls_threads

    !> 'auto': decide (once a pattern: n and nnz(J0) unchanged keep the decision) from
    !> the symbolic analysis of a (chol_analyse, kept for the factorization that follows
    !> when the direct solver is chosen, released when CG is). Not symmetric, or 1D: the
    !> direct solver, without an analysis.
    subroutine auto_decide(f, a, stat, errmsg, val)
        type(factor_t), intent(inout) :: f                  !! solver
        type(csc_t), intent(in) :: a                        !! matrix
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), intent(in), optional :: val(:)            !! values on a's pattern (for a%val)
        integer(c_long) :: entries
        integer :: env, min_dofs
        stat = STAT_OK
        if (f%auto_n == a%n .and. f%auto_nnz == int(a%nnz, i8) .and. f%auto_kind /= '') return
        f%auto_n = a%n
        f%auto_nnz = int(a%nnz, i8)
        f%auto_factor_nnz = 0
        f%auto_kind = 'direct'
        call ldl_threads_env(env, min_dofs)
        f%auto_threads = ldl_threads_choice(f%threads, env, ldl_cpus(), a%n, min_dofs)
        if (.not. f%symmetric .or. f%dim < 2 .or. f%dim > 3) return
        call chol_analyse(f%ch, a, entries, stat, errmsg, val)
        if (stat /= STAT_OK) return
        f%auto_factor_nnz = int(entries, i8)
        f%auto_kind = ls_auto_kind('auto', f%dim, f%auto_nnz, f%auto_factor_nnz, f%auto_threads)
        if (f%auto_kind == 'cg') call chol_free(f%ch)
    end subroutine auto_decide

    !> Set the solver kind of the next ls_factor calls: 'direct', 'cg' or 'auto' (the
    !> cost model of ls_auto_kind, on the symbolic analysis of the matrix), with the CG
    !> tolerance and iteration limit.
    pure subroutine ls_configure(f, kind, dim, cg_rtol, cg_max_iter)
        type(factor_t), intent(inout) :: f                  !! solver (before ls_factor)
        character(len=*), intent(in) :: kind                !! 'direct', 'cg' or 'auto'
        integer, intent(in) :: dim                          !! mesh dimension (1 to 3)
        real(dp), intent(in) :: cg_rtol                     !! CG relative residual tolerance
        integer, intent(in) :: cg_max_iter                  !! CG iteration limit
        f%kind = kind
        f%dim = dim
        f%cg_rtol = cg_rtol
        f%cg_max_iter = cg_max_iter
        f%auto_n = 0
        f%auto_kind = ''
    end subroutine ls_configure

    !> The kind that runs for a requested kind, a mesh of dimension dim, a matrix with
    !> matrix_nnz entries and a factor of factor_nnz entries (D and L, from the symbolic
    !> analysis; <= 0: unknown) whose direct solve runs on `threads` threads (default 1):
    !> 'cg' or 'direct'. 'auto' is 'cg' when AUTO_CG_ITS(dim) matrix_nnz <
    !> AUTO_CG_MARGIN(dim) factor_nnz / s (2D, 3D; s = AUTO_PAR_SPEEDUP with two threads,
    !> else 1), else 'direct'.
    pure function ls_auto_kind(kind, dim, matrix_nnz, factor_nnz, threads) result(k)
        character(len=*), intent(in) :: kind                !! 'direct', 'cg' or 'auto'
        integer, intent(in) :: dim                          !! mesh dimension (0: unknown)
        integer(i8), intent(in) :: matrix_nnz               !! entries (both triangles)
        integer(i8), intent(in) :: factor_nnz               !! entries of its LDL^T factor
        integer, intent(in), optional :: threads            !! the direct solve's (1, 2)
        character(len=:), allocatable :: k
        k = 'direct'
        if (trim(kind) == 'cg') then
            k = 'cg'
        else if (trim(kind) == 'auto' .and. dim >= 2 .and. dim <= 3 .and. factor_nnz > 0) then
            if (real(AUTO_CG_ITS(dim), dp) * real(matrix_nnz, dp) &
                < AUTO_CG_MARGIN(dim) * real(factor_nnz, dp) / direct_speedup(threads)) k = 'cg'
        end if
    end function ls_auto_kind

    !> The cost model's speedup of a direct solve on `threads` threads: AUTO_PAR_SPEEDUP
    !> for two, 1 for one (or not given).
    pure real(dp) function direct_speedup(threads) result(s)
        integer, intent(in), optional :: threads            !! 1 or 2
        s = 1.0_dp
        if (present(threads)) then
            if (threads >= 2) s = AUTO_PAR_SPEEDUP
        end if
    end function direct_speedup

    !> 'auto''s decision and its inputs, for the run's summary: e.g. "cg: 8 x nnz(J0)
    !> 659432 < 1.9 x factor entries 3166928 (ratio 1.666)"; with a two-thread direct solve
    !> "cg: 8 x nnz(J0) 659432 < 1.9 x factor entries 3173896 / 1.00, the direct solve
    !> on 2 threads (ratio 1.662)"; '' when the kind is not 'auto' or before the
    !> first ls_factor.
    pure function ls_auto_reason(f) result(text)
        type(factor_t), intent(in) :: f      !! solver
        character(len=:), allocatable :: text
        character(len=160) :: buf
        character(len=60) :: par
        character(len=3) :: rel
        text = ''
        if (trim(f%kind) /= 'auto' .or. f%auto_kind == '') return
        rel = ' >='
        if (f%auto_kind == 'cg') rel = ' <'
        if (f%auto_factor_nnz <= 0) then
            if (f%dim < 2 .or. f%dim > 3) then
                text = 'direct: 1D or dimension unknown'
            else
                text = 'direct: the matrix is not symmetric'
            end if
            return
        end if
        par = ''
        if (f%auto_threads >= 2) write (par, '(a, f4.2, a)') ' / ', AUTO_PAR_SPEEDUP, &
            ', the direct solve on 2 threads'
        write (buf, '(a, a, i0, a, i0, a, f3.1, a, i0, a)') trim(f%auto_kind), ': ', &
            AUTO_CG_ITS(f%dim), ' x nnz(J0) ', f%auto_nnz, trim(rel)//' ', &
            AUTO_CG_MARGIN(f%dim), ' x factor entries ', f%auto_factor_nnz, trim(par)
        ! the ratio can be below 1 (a factor of more than 8 entries per J0 entry), where the
        ! f0.3 edit descriptor would write '.850'
        text = trim(buf)//' (ratio '//fixed_text(real(AUTO_CG_ITS(f%dim), dp) &
            * real(f%auto_nnz, dp) / real(f%auto_factor_nnz, dp), 3)//')'
    end function ls_auto_reason

    !> CG counters: solves, iterations over them, the most of one solve (0 without CG).
    pure subroutine ls_cg_counts(f, solves, iterations, max_its)
        type(factor_t), intent(in) :: f                     !! solver
        integer(i8), intent(out) :: solves, iterations      !! solves, iterations
        integer, intent(out) :: max_its                     !! most iterations of one solve
        solves = f%cg%solves
        iterations = f%cg%iterations
        max_its = f%cg%max_its
    end subroutine ls_cg_counts

    !> The direct factorization of ls_factor (LDL^T, else LU).
    subroutine direct_factor(f, a, stat, errmsg, val)
        type(factor_t), intent(inout) :: f                  !! factors (created or replaced)
        type(csc_t), intent(in) :: a                        !! matrix
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), intent(in), optional :: val(:)            !! values on a's pattern (for a%val)
        call pcg_free(f%cg)
        if (f%symmetric) then
            call chol_factor(f%ch, a, stat, errmsg, val)
            if (stat == STAT_OK) then
                call lu_free(f%lu)
                f%backend = BACKEND_CHOLMOD
                f%n = a%n
                f%factorizations = f%factorizations + 1
                f%threads_used = 1
                if (f%ch%pairs%n > 0) call pair_ldl_threads(f%ch%pairs, f%threads, f%threads_used)
                if (f%ch%triples%n > 0) &
                    call triple_ldl_threads(f%ch%triples, f%threads, f%threads_used)
                return
            end if
            if (stat /= STAT_NUMERIC) return
            f%fell_back = .true.
        end if
        call chol_free(f%ch)
        call lu_factor(f%lu, a, stat, errmsg, val)
        if (stat /= STAT_OK) return
        f%backend = BACKEND_UMFPACK
        f%n = a%n
        f%factorizations = f%factorizations + 1
    end subroutine direct_factor

    !> After a CG solve that returned stat: `done` unless the solve proved a not positive
    !> definite, or 'auto' chose CG and it did not converge (its cost model assumes the
    !> iterations of a mass-dominated J0; a large dt makes K dominate and CG slow, where
    !> the direct solve costs the same); then a is factorized directly (for the rest of the
    !> run, said in f%note) and `done` only when that failed (stat), else the caller solves
    !> with the factors.
    subroutine cg_fall_back(f, a, stat, errmsg, done, val)
        type(factor_t), intent(inout) :: f                  !! solver
        type(csc_t), intent(in) :: a                        !! matrix
        integer, intent(inout) :: stat                      !! CG's status, then the factorization's
        character(len=*), intent(inout), optional :: errmsg !! message
        logical, intent(out) :: done                        !! the caller returns stat
        real(dp), intent(in), optional :: val(:)            !! values on a's pattern (for a%val)
        logical :: slow
        slow = stat == STAT_NUMERIC .and. trim(f%kind) == 'auto' .and. .not. f%cg%indefinite
        done = stat == STAT_OK .or. .not. (f%cg%indefinite .or. slow)
        if (done) return
        if (slow) then
            f%note = 'auto: conjugate gradients did not converge within &solver cg_max_iter '// &
                     '= '//int_text(f%cg%max_iter)//' iterations: the matrix was factorized directly'
        else
            f%note = 'conjugate gradients met a curvature <= 0 (the matrix is not positive '// &
                     'definite): it was factorized directly'
        end if
        call direct_factor(f, a, stat, errmsg, val)
        done = stat /= STAT_OK
    end subroutine cg_fall_back

    !> Solve A x = b with the factors of a (no allocation). b and x must have n entries.
    !> With `guess` true, x holds a first guess, which CG starts from (the direct solves
    !> ignore it). `val`: as given to ls_factor.
    subroutine ls_solve(f, a, b, x, stat, errmsg, guess, val)
        type(factor_t), intent(inout) :: f                  !! factors of a
        type(csc_t), intent(in) :: a                        !! the factorized matrix
        real(dp), intent(in) :: b(:)                        !! right-hand side (n)
        real(dp), intent(inout) :: x(:)                     !! guess (with `guess`), solution (n)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        logical, intent(in), optional :: guess              !! x holds a first guess (CG)
        real(dp), intent(in), optional :: val(:)            !! (a%nnz) values on a's pattern
        logical :: done
        if (f%n /= a%n .or. f%n < 1) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'ls_solve: no factors of this matrix')
            return
        end if
        if (f%backend == BACKEND_PCG) then
            call pcg_solve(f%cg, a, b, x, stat, errmsg, guess, val)
            call cg_fall_back(f, a, stat, errmsg, done, val)
            if (done) return
        end if
        if (f%backend == BACKEND_CHOLMOD) then
            call chol_solve(f%ch, b, x, stat, errmsg)
        else
            call lu_solve(f%lu, a, b, x, stat, errmsg)
        end if
    end subroutine ls_solve

    !> Solve A X = B for the columns of B (CHOLMOD: one blocked solve, or column after
    !> column with the factor by node blocks; UMFPACK: one column after the other).
    !> `val`: as given to ls_factor.
    subroutine ls_solve_many(f, a, b, x, stat, errmsg, val)
        type(factor_t), intent(inout) :: f                  !! factors of a
        type(csc_t), intent(in) :: a                        !! the factorized matrix
        real(dp), intent(in) :: b(:, :)                     !! right-hand sides (n, m)
        real(dp), intent(out) :: x(:, :)                    !! solutions (n, m)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), intent(in), optional :: val(:)            !! (a%nnz) values on a's pattern
        logical :: done
        if (size(b, 2) /= size(x, 2)) then
            call raise(stat, errmsg, STAT_BAD_INPUT, &
                       'ls_solve_many: b and x have different numbers of columns')
            return
        end if
        if (f%n /= a%n .or. f%n < 1) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'ls_solve_many: no factors of this matrix')
            return
        end if
        if (f%backend == BACKEND_PCG) then
            call pcg_solve_many(f%cg, a, b, x, stat, errmsg, val)
            call cg_fall_back(f, a, stat, errmsg, done, val)
            if (done) return
        end if
        if (f%backend == BACKEND_CHOLMOD) then
            call chol_solve_many(f%ch, b, x, stat, errmsg)
        else
            call lu_solve_many(f%lu, a, b, x, stat, errmsg)
        end if
    end subroutine ls_solve_many

    !> The triangular solve ls_solve runs: 'ldl_node_pairs' (LDL^T by 2x2 node blocks),
    !> 'cholmod_solve2', 'umfpack', or 'pcg' (no factors: CG) ('' without either).
    pure function ls_kernel(f) result(name)
        type(factor_t), intent(in) :: f      !! factors
        character(len=:), allocatable :: name
        if (f%n < 1) then
            name = ''
        else if (f%backend == BACKEND_CHOLMOD) then
            name = chol_kernel(f%ch)
        else if (f%backend == BACKEND_PCG) then
            name = BACKEND_PCG
        else
            name = 'umfpack'
        end if
    end function ls_kernel

    !> The fill-reducing ordering of the LDL^T factors ('amd', 'metis', 'nesdis',
    !> 'cholmod'; 'umfpack' for the LU, whose ordering is UMFPACK's own; '' without
    !> factors or with CG) and the entries stored in the LDL^T factor (D and L; 0 for the
    !> LU and CG).
    pure subroutine ls_factor_info(f, ordering, nnz)
        type(factor_t), intent(in) :: f                      !! factors
        character(len=:), allocatable, intent(out) :: ordering  !! ordering's name
        integer(i8), intent(out) :: nnz                      !! stored entries
        ordering = ''
        nnz = 0
        if (f%n < 1) return
        if (f%backend == BACKEND_CHOLMOD) then
            ordering = chol_ordering(f%ch)
            nnz = int(f%ch%factor_nnz, i8)
        else if (f%backend == BACKEND_PCG) then
            ordering = ''
        else
            ordering = 'umfpack'
        end if
    end subroutine ls_factor_info

    !> The numerical factorization of the LDL^T factors: 'supernodal' (CHOLMOD's
    !> supernodal LL^T, then solved as LDL^T by node blocks where the matrix has them) or
    !> 'simplicial' (CHOLMOD's simplicial LDL^T); '' for the LU, CG or without factors.
    pure function ls_factorization(f) result(name)
        type(factor_t), intent(in) :: f      !! factors
        character(len=:), allocatable :: name
        name = ''
        if (f%n < 1 .or. f%backend /= BACKEND_CHOLMOD) return
        name = 'simplicial'
        if (f%ch%supernodal) name = 'supernodal'
    end function ls_factorization

    !> Release every backend's factors (safe to call twice). The counters are kept.
    subroutine ls_free(f)
        type(factor_t), intent(inout) :: f   !! factors to release
        call chol_free(f%ch)
        call lu_free(f%lu)
        call pcg_free(f%cg)
        f%n = 0
    end subroutine ls_free

    !> a has a symmetric pattern (entries stored without a partner must be zero) and
    !> values symmetric to SYM_RTOL (n >= 1, CSC arrays allocated; .false. otherwise).
    !> With `val`, the matrix with a's pattern and those values.
    pure function csc_is_symmetric(a, val) result(sym)
        type(csc_t), intent(in) :: a                !! matrix (its pattern)
        real(dp), intent(in), optional :: val(:)    !! (a%nnz) values on a's pattern
        logical :: sym
        sym = .false.
        if (a%n < 1 .or. .not. (allocated(a%colptr) .and. allocated(a%rowind))) return
        if (size(a%colptr) < a%n + 1) return
        if (a%colptr(a%n + 1) /= a%nnz .or. size(a%rowind) < a%nnz) return
        if (present(val)) then
            if (size(val) >= a%nnz) sym = symmetric_values(a, val)
        else if (allocated(a%val)) then
            if (size(a%val) >= a%nnz) sym = symmetric_values(a, a%val)
        end if
    end function csc_is_symmetric

    !> csc_is_symmetric for the values v on a's pattern (both checked).
    pure function symmetric_values(a, v) result(sym)
        type(csc_t), intent(in) :: a                !! the pattern
        real(dp), intent(in) :: v(:)                !! (a%nnz) the values
        logical :: sym
        integer :: i, j, k, p
        real(dp) :: s
        sym = .false.
        do j = 1, a%n
            do k = a%colptr(j) + 1, a%colptr(j + 1)
                i = a%rowind(k) + 1
                if (i == j) cycle
                p = csc_find(a, j, i)
                if (p == 0) then
                    if (v(k) /= 0.0_dp) return
                else if (i < j) then
                    s = max(abs(v(k)) + abs(v(p)), sqrt(abs(diag(i) * diag(j))))
                    if (abs(v(k) - v(p)) > SYM_RTOL * s) return
                end if
            end do
        end do
        sym = .true.
    contains
        !> a_ii (0 if not stored).
        pure real(dp) function diag(ii)
            integer, intent(in) :: ii   !! row = column (1-based)
            integer :: q
            q = csc_find(a, ii, ii)
            diag = 0.0_dp
            if (q > 0) diag = v(q)
        end function diag
    end function symmetric_values
end module linear_solver

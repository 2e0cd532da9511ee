!> Implicit schemes newmark, hht, hht_seed and theta over one semi-smooth Newton
!> driver. Every step solves
!>     R(x) = M (x - u~) + c B(x) - b = 0,   J = M + c B'(x),
!> with u~, c, b set by the scheme:
!>   Newmark family (newmark, hht, hht_seed, galpha), in generalized-alpha form:
!>     (1-am) M a' + am M a + (1-af) B(u') + af B(u) = L, u' = u~ + beta dt^2 a',
!>     u~ = u + dt v + dt^2 (1/2 - beta) a, v' = v + dt ((1-gamma) a + gamma a');
!>     newmark: am = af = 0; hht/hht_seed (alpha <= 0): am = 0, af = -alpha;
!>     galpha (Chung-Hulbert 1993, rho_inf in [0, 1]): am = (2 rho - 1)/(rho + 1),
!>     af = rho/(rho + 1), beta = (1 - am + af)^2/4, gamma = 1/2 - am + af.
!>     Multiplied by beta dt^2/(1-am): c = beta dt^2 (1-af)/(1-am),
!>     b = beta dt^2/(1-am) (L - af B(u)), and M (u - u~) becomes M (u - u~ + k a) with
!>     k = beta dt^2 am/(1-am) (k = 0 and the same operations as plain HHT when am = 0).
!>   theta: u' = u + dt (theta v' + (1-theta) v), M (v' - v) = dt (L - theta B(u')
!>     - (1-theta) B(u)), so u~ = u + dt v, c = theta^2 dt^2,
!>     b = theta dt^2 (L - (1-theta) B(u)).
!> State: u, v, a are the only copies of the truth. The predictor u~ is formed as a
!> vector and M (u^n - u~) by a product with M (as GetFEM does); a' = (x - u~) /
!> (beta dt^2) and v' are formed from vectors; M v' is a product formed at the end of
!> the step, in the same pass over the node blocks as K_theta u' and the next step's
!> M (u' - u~'). No product is carried across steps by an update identity, so none
!> can drift from the vector it stands for.
!> J = J0 + c P^T U V^T P where J0 = M + c K_theta is factorized once and
!> D = U V^T (one rank-one term per active contact quadrature point, or nfn a facet
!> when more of its points are active, nitsche_facet's nterm; on the dofs of the
!> contact cells) is the contact tangent: J^{-1} is applied with the Woodbury
!> identity, so the active set changing never costs a factorization. Only the first
!> Newton iteration solves with J0 (y0 = J0^{-1} R(u^n)); every correction after it
!> lies in the range of Z = J0^{-1} P^T, so the iterations run on the m contact-cell
!> dofs alone with W = P Z, accumulating the coefficients T of x = u^n - y0 - Z T, and
!> Z T is applied once at the end of the step: a contact step costs one sparse solve,
!> like a contact-free one. T, the Woodbury terms and the residual's contact part live
!> on the dofs of the cells with an active contact point (at some iterate of the step),
!> so only those columns of Z and W are used: they are solved when a dof first needs
!> them and kept in a bounded cache (module contact_columns), and the sums over them
!> run in the order of the contact-cell dofs, as over the whole of W and Z. With the
!> augmented Lagrangian every column is computed at set-up (its Newton uses all of W).
!> The environment variable DYNCONTACT_CONTACT_COLUMNS = 'all' computes every column at
!> set-up for the Nitsche schemes too (the reference the lazy columns are tested
!> against); a number sets the cache's budget in MB (0: keep only the current step's).
!> The LU factors of the Woodbury system I + c V^T W U are kept with a copy of what
!> they were formed from (the terms' facets and their coefficients tca, tcb: the
!> system is formed from those alone, woodbury_factor and node_factor), and used again,
!> across Newton iterations and steps, while these are that copy bit for bit (W depends
!> on J0 alone): the same system, so the same factors and the same Newton step to the
!> bit. A
!> 'gauss' rule gives the same tangent whenever the same points are active; 'exact' as
!> long as no active facet is cut. The system is formed from X = M^T W Mt over the
!> facets with active points (woodbury_factor), which depends on those facets alone and
!> is kept while they are the same. DYNCONTACT_WOODBURY_FRESH = 1 (read at set-up) forms
!> X and the system and factorizes it at every iteration (the reference the reuse is
!> tested against, tests/test_woodbury_reuse.py). When the terms' facets share nodes
!> (3D) the system is formed on a smaller basis: every term lies on its facet's columns
!> s_f - gamma_f n_j, so D = B H B^T with B = [s_f of each facet, n_j of each facet
!> node] and the system I + c Y H, Y = B^T W B (kept while the facets are the same), has
!> the order facets + nodes (node_basis; 57 against a rank of 96 for 32 facets on 25
!> nodes); DYNCONTACT_WOODBURY_BASIS = terms (read at set-up) keeps it on the terms (the
!> reference, tests/test_woodbury_basis.py).
!> Z T is applied on the same kind of basis: T is a sum of contact residuals, tangent
!> terms and Woodbury corrections, each a combination of the vectors s_f (every facet)
!> and n_j (every facet node), so along with T on the contact-cell dofs the Newton
!> carries its coefficients tau on those vectors (contact_eval gives each facet's
!> residual in its Mt, the terms their coefficients), and Z T = sum_k tau_k Z b_k reads
!> one kept column Z s_f or Z n_j a vector (contact_columns' basis columns) instead of
!> one column of Z a dof: 57 against ~150 on the box at h = 0.025. The rows of dx on the
!> contact-cell dofs are then set to the Newton's own P dx = P y0 + W T, so that the
!> contact part kept for the next step is C at P u' bit for bit; the other rows differ
!> from y0 + Z T by round-off. Taken when Z is kept whole, when Z and the vectors'
!> columns fit in the cache's default budget (the columns are held in the cache, within
!> its budget), and at a step where fewer coefficients than dofs are nonzero;
!> DYNCONTACT_ZT_BASIS = dofs (read at set-up) always applies Z T on the dofs (the
!> reference, tests/test_zt_basis.py).
module implicit_schemes
    use kinds, only: dp, i8
    use vector_ops, only: dot, lane_sum, LANES
    use text, only: int_text, real_text, env_text, counted
    use errors, only: STAT_OK, STAT_NUMERIC, raise
    use linear_solver, only: factor_t, ls_factor, ls_solve, ls_solve_many, ls_free, ls_kernel, &
                             ls_factor_info, ls_configure, ls_cg_counts, BACKEND_PCG
    use dense_lu, only: dense_lu_factor, dense_lu_solve
    use model, only: model_t, model_eval_b, model_mass_apply, model_step_products
    use nitsche_contact, only: contact_eval, contact_clear, contact_max_rank, MAX_E, MAX_FN, &
                               E_2D
    use alm_contact, only: ALM_OFF, alm_resultant
    use alm_newton, only: alm_newton_t, alm_newton_init, alm_newton_solve
    use contact_columns, only: zcache_t, zcache_init, zcache_new_step, zcache_ensure, &
                               zcache_ensure_all, zcache_w_times, zcache_add_w, zcache_add_z, &
                               zcache_free, zcache_basis_init, zcache_basis_ensure, &
                               zcache_add_basis, zcache_save, zcache_load, zcache_restore, &
                               zcache_basis_reform, zcache_restore_finish
    use mass_solver, only: mass_solver_t, mass_solver_start, mass_solver_free
    use byte_buffer, only: byte_buffer_t, buf_put, buf_get
    use time_scheme, only: time_scheme_t, state_t, scheme_params_t, SCHEME_NEWMARK, SCHEME_HHT, &
                           SCHEME_HHT_SEED, SCHEME_GALPHA, FAILURE_STEP, FAILURE_CG, &
                           step_failed, step_solve_failed
    implicit none
    private

    integer, parameter :: KIND_NEWMARK = 1   ! newmark, hht, hht_seed
    integer, parameter :: KIND_THETA = 2     ! theta
    !> The environment variable that forces the full precomputation or sets the budget.
    character(len=*), parameter :: COLUMNS_VAR = 'DYNCONTACT_CONTACT_COLUMNS'
    !> The least budget of the column cache, bytes.
    integer(i8), parameter :: BUDGET_MIN = 64_i8 * 1024_i8**2
    !> The environment variable that turns the reuse of the Woodbury factors off ('1').
    character(len=*), parameter :: FRESH_VAR = 'DYNCONTACT_WOODBURY_FRESH'
    !> The environment variable that keeps the Woodbury system on the terms ('terms'):
    !> never the smaller node basis (the reference that basis is tested against).
    character(len=*), parameter :: BASIS_VAR = 'DYNCONTACT_WOODBURY_BASIS'
    !> The environment variable that applies Z T on the contact-cell dofs ('dofs'):
    !> never on the node basis (the reference that basis is tested against).
    character(len=*), parameter :: ZT_VAR = 'DYNCONTACT_ZT_BASIS'
    !> The environment variable that makes the Newmark family solve M a0 = L - B(u0) even
    !> when L - B(u0) is zero ('solve'): a test-only switch, to check that skipping the
    !> factorization then leaves every result unchanged bit for bit.
    character(len=*), parameter :: A0_VAR = 'DYNCONTACT_INITIAL_SOLVE'

    !> Newmark-family and theta schemes.
    type, extends(time_scheme_t), public :: implicit_scheme_t
        integer :: kind = KIND_NEWMARK            !! family
        real(dp) :: alpha_m = 0.0_dp              !! generalized-alpha alpha_m (0 but for galpha)
        real(dp) :: alpha_f = 0.0_dp              !! alpha_f (-alpha for hht, hht_seed)
        real(dp) :: beta = 0.25_dp                !! Newmark beta
        real(dp) :: gamma = 0.5_dp                !! Newmark gamma
        real(dp) :: theta = 0.5_dp                !! theta-scheme theta
        real(dp) :: c = 0.0_dp                    !! coefficient of B in R
        real(dp) :: tol = 1.0e-10_dp              !! relative residual tolerance
        integer :: maxit = 50                     !! Newton iteration limit
        real(dp), allocatable :: jac0(:)          !! (nnz) J0 = M + c K_theta: its values on the
                                                  !! model's pattern (mdl%stiff's), no copy of it
        type(factor_t) :: lu0                     !! its factors
        integer :: m = 0                          !! contact-cell dofs
        type(zcache_t) :: zc                      !! columns of Z = J0^{-1} P^T and W = P Z
        logical :: all_columns = .false.          !! every column computed at set-up
        integer, allocatable :: need(:)           !! (max(m, ndof_e rmax)) columns a step needs
        integer, allocatable :: fneed(:)          !! (n_facets) the cache's step at which a
                                                  !! facet's columns were last made available
        integer :: rank = 0                       !! rank of the contact tangent D = U V^T
        real(dp), allocatable :: ua(:, :)         !! (ndof_e, rmax) columns of U (on qloc)
        real(dp), allocatable :: vb(:, :)         !! (ndof_e, rmax) columns of V (on qloc)
        integer, allocatable :: qloc(:, :)        !! (ndof_e, rmax) their contact-cell dofs
        real(dp), allocatable :: small(:, :)      !! (cap, cap) Woodbury system I + c V^T W U
        real(dp), allocatable :: zs(:)            !! (cap) its right-hand side / solution
        integer, allocatable :: piv(:)            !! (cap) pivots
        logical :: fresh = .false.                !! never reuse the factors (FRESH_VAR)
        integer :: fac_rank = -1                  !! rank of the factorized system, -1: none
        integer, allocatable :: tfac(:)           !! (rmax) each term's facet
        real(dp), allocatable :: tca(:, :)        !! (nfn, rmax) its coefficients in the facet's Mt
        real(dp), allocatable :: tcb(:, :)        !! (nfn, rmax) and in its M
        integer :: nxf = -1                       !! facets of X (-1: none formed)
        integer, allocatable :: xfac(:)           !! (n_facets) those facets, in order
        integer, allocatable :: flist(:)          !! (n_facets) the current terms' facets (work)
        integer, allocatable :: fblk(:)           !! (n_facets) a facet's block in X
        real(dp), allocatable :: wxu(:, :)        !! (m, kcap) W Mt over the facets of X
        real(dp), allocatable :: xt(:, :)         !! (kcap, kcap) X^T, X = M^T W Mt
        real(dp), allocatable :: yrow(:)          !! (kcap) one row of Cb^T X
        logical :: terms_only = .false.           !! never the node basis (BASIS_VAR)
        logical :: fac_nodes = .false.            !! the factors held are of the node basis
        integer, allocatable :: fac_tfac(:)       !! (rmax) the factorized terms' facets
        real(dp), allocatable :: fac_tca(:, :)    !! (nfn, rmax) and their coefficients
        real(dp), allocatable :: fac_tcb(:, :)    !! (nfn, rmax)
        real(dp), allocatable :: halpha(:, :)     !! (0:nfn, rmax) the factorized terms' alpha_t
        real(dp), allocatable :: hbeta(:, :)      !! (0:nfn, rmax) and beta_t on the node basis
                                                  !! (term_coefficients; node_factor, node_solve)
        integer :: nq = 0                         !! size of the node basis of the terms
        logical :: ybas_ok = .false.              !! ybas is Y of the basis held
        integer :: nyf = -1                       !! facets of Y (-1: none formed)
        integer, allocatable :: yfac(:)           !! (n_facets) those facets, in order
        integer, allocatable :: qnode(:, :)       !! (0:nfn, n_facets) basis index of a facet
                                                  !! (row 0) and of its nodes
        integer, allocatable :: bnode(:)          !! (>= facets nfn) the basis' nodes
        integer, allocatable :: bcn(:)            !! (>= facets nfn) and their contact nodes
        integer, allocatable :: nrow(:, :)        !! (nfn, .) a node vector's contact-cell dofs
        real(dp), allocatable :: nval(:, :)       !! (nfn, .) and its entries (the normal)
        real(dp), allocatable :: wb(:, :)         !! (m, qcap) W B over the basis
        real(dp), allocatable :: ybas(:, :)       !! (qcap, qcap) Y = B^T W B
        real(dp), allocatable :: qa(:), qs(:)     !! (qcap) Y alpha_t, H s (work)
        real(dp), allocatable :: tvec(:)          !! (m) D P dx, the tangent's part of R'
        real(dp), allocatable :: cx(:), cold(:)   !! (m) contact part of B at the iterate, previous
        real(dp), allocatable :: rho(:)           !! (m) R on the contact-cell dofs (zero elsewhere)
        real(dp), allocatable :: xbase(:)         !! (m) P (u^n - y0)
        real(dp), allocatable :: xc(:), dxc(:)    !! (m) P x, P dx
        real(dp), allocatable :: yc(:), tk(:)     !! (m) P J0^{-1} R and one iteration's coefficients
        real(dp), allocatable :: tsum(:)          !! (m) T, the coefficients of Z in x
        real(dp), allocatable :: y0c(:)           !! (m) P y0
        logical :: zt_basis = .false.             !! Z T applied on the node basis (see header)
        integer :: ncn = 0                        !! contact nodes (the facets' nodes)
        integer, allocatable :: cnode(:, :)       !! (nfn, n_facets) a facet node's contact node
        integer, allocatable :: cnf(:, :)         !! (2, ncn) a facet of the node, its place there
        real(dp), allocatable :: tau(:)           !! (n_facets + ncn) T on [s_f, n_j]
        real(dp), allocatable :: gx(:, :)         !! (nfn, n_facets) cx = sum_f Mt_f gx(:, f)
        real(dp), allocatable :: gold(:, :)       !! (nfn, n_facets) the same for cold
        real(dp), allocatable :: rhog(:, :)       !! (nfn, n_facets) the same for rho
        real(dp), allocatable :: pdx(:)           !! (m) P dx = y0c + W T at the last iterate
        logical :: rhog_due = .false.             !! rhog holds the tangent part only (see
                                                  !! contact_residual, rhog_finish)
        logical :: cached = .false.               !! cx, the tangent and st%active/e_pen/e_theta
                                                  !! are C at xc (kept from the last step)
        real(dp) :: kga = 0.0_dp                  !! beta dt^2 am/(1-am) (generalized-alpha)
        real(dp), allocatable :: vq(:)            !! (massless dofs) their v' = (u' - u)/dt
        integer :: lu0_counted = 0                !! lu0%factorizations already in factorizations
        real(dp), allocatable :: md(:)            !! (n) M (u - u~) of the next step
        real(dp), allocatable :: dvec(:)          !! (n) u - u~ (the vector multiplied by M)
        real(dp), allocatable :: r(:), dx(:), x(:), scratch(:)  !! (n) work vectors
        type(alm_newton_t) :: almn                !! Newton on (u, lambda) (augmented Lagrangian)
    contains
        procedure :: init => implicit_init
        procedure :: step => implicit_step
        procedure :: free => implicit_free
        procedure :: solver => implicit_solver
        procedure :: kernel => implicit_kernel
        procedure :: save => implicit_save
        procedure :: load => implicit_load
        procedure :: factor_info => implicit_factor_info
    end type implicit_scheme_t

    public :: implicit_solver_report, implicit_restore_columns

contains

    !> Coefficients from the parameters, J0 factorization, Woodbury blocks, and the
    !> initial acceleration M a0 = L - B(u0) for the Newmark family.
    subroutine implicit_init(this, mdl, prm, st, stat, errmsg)
        use model, only: model_stiff_theta_values, model_mass_definite
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        type(scheme_params_t), intent(in) :: prm            !! parameters (kind: an implicit one)
        type(state_t), intent(inout) :: st                  !! initial state
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        type(mass_solver_t) :: ms
        integer :: n, rmax
        integer(i8) :: budget
        n = mdl%n_dofs
        this%dt = prm%dt
        this%tol = prm%newton_tol
        this%maxit = prm%newton_maxit
        select case (prm%kind)
        case (SCHEME_NEWMARK)
            this%kind = KIND_NEWMARK
            this%beta = prm%beta; this%gamma = prm%gamma
        case (SCHEME_HHT)
            this%kind = KIND_NEWMARK; this%alpha_f = -prm%alpha
            this%beta = (1.0_dp - prm%alpha)**2 / 4.0_dp; this%gamma = 0.5_dp - prm%alpha
        case (SCHEME_HHT_SEED)
            this%kind = KIND_NEWMARK; this%alpha_f = -prm%alpha
            this%beta = (1.0_dp + prm%alpha)**2 / 4.0_dp; this%gamma = 0.5_dp + prm%alpha
        case (SCHEME_GALPHA)
            this%kind = KIND_NEWMARK
            this%alpha_m = (2.0_dp * prm%rho_inf - 1.0_dp) / (prm%rho_inf + 1.0_dp)
            this%alpha_f = prm%rho_inf / (prm%rho_inf + 1.0_dp)
            this%beta = (1.0_dp - this%alpha_m + this%alpha_f)**2 / 4.0_dp
            this%gamma = 0.5_dp - this%alpha_m + this%alpha_f
        case default    ! SCHEME_THETA
            this%kind = KIND_THETA; this%theta = prm%theta
        end select
        if (this%kind == KIND_NEWMARK) then
            this%c = this%beta * this%dt**2 * (1.0_dp - this%alpha_f) / (1.0_dp - this%alpha_m)
            this%kga = this%beta * this%dt**2 * this%alpha_m / (1.0_dp - this%alpha_m)
        else
            this%c = (this%theta * this%dt)**2
        end if
        allocate (this%md(n), this%dvec(n))

        ! initial acceleration (Newmark family only): M a0 = L - B(u0), one factorization
        ! of M (or S) freed at once. Where L - B(u0) is zero at every dof (no load and
        ! u0 = 0, or u0 in equilibrium with L), a0 = 0 exactly, what the solve returns
        ! (the factors applied to zeros), and M is not factorized
        if (this%kind == KIND_NEWMARK .and. .not. at_rest()) then
            call mass_solver_start(ms, mdl, st%bu, st%a, this%factorizations, stat, errmsg, &
                                   once=.true.)
            call mass_solver_free(ms)
            if (stat /= STAT_OK) return
        else
            ! M is not factorized: its definiteness (redistributed mass) is checked alone,
            ! in J0's factors, whose factorization then reuses the check's analysis (the
            ! same pattern: the model's); the check's factorization (of S or M) is counted
            call model_mass_definite(mdl, stat, errmsg, this%lu0%ch, this%factorizations)
            if (stat /= STAT_OK) return
            st%a = 0.0_dp
        end if
        ! the first step's predictor u~ and M (u0 - u~)
        call form_predictor(this, st%u, st%v, st%a)
        call model_mass_apply(mdl, this%dvec, this%md)

        allocate (this%jac0(mdl%stiff%nnz))   ! on the model's pattern (M's, K's and K_theta's)
        call model_stiff_theta_values(mdl, this%jac0)   ! K_theta's values, in place
        this%jac0 = mdl%mass_val + this%c * this%jac0
        call ls_configure(this%lu0, prm%solver_kind, mdl%dim, prm%cg_rtol, prm%cg_max_iter)
        call ls_factor(this%lu0, mdl%stiff, stat, errmsg, val=this%jac0)
        if (stat /= STAT_OK) return
        call count_lu0(this)      ! 1, or 0 when CG runs
        ! the step's vectors, allocated after J0's factorization: not held at its peak
        allocate (this%r(n), this%dx(n), this%x(n), this%scratch(n))

        this%m = 0
        if (mdl%has_contact) this%m = mdl%ct%m
        rmax = 0
        if (mdl%has_contact) rmax = contact_max_rank(mdl%ct)
        allocate (this%need(max(this%m, mdl%ndof_e * rmax)), this%ua(mdl%ndof_e, rmax), &
                  this%vb(mdl%ndof_e, rmax), this%qloc(mdl%ndof_e, rmax), &
                  this%tfac(rmax), this%fac_tfac(rmax), this%fneed(mdl%ct%n_facets), &
                  this%fac_tca(max(1, mdl%ct%nfn), rmax), this%fac_tcb(max(1, mdl%ct%nfn), rmax), &
                  this%halpha(0:max(1, mdl%ct%nfn), rmax), this%hbeta(0:max(1, mdl%ct%nfn), rmax), &
                  this%yfac(mdl%ct%n_facets), this%qnode(0:max(1, mdl%ct%nfn), mdl%ct%n_facets), &
                  this%bnode(0), this%nrow(max(1, mdl%ct%nfn), 0), &
                  this%nval(max(1, mdl%ct%nfn), 0), this%wb(this%m, 0), this%ybas(0, 0), &
                  this%qa(0), this%qs(0), &
                  this%tca(max(1, mdl%ct%nfn), rmax), this%tcb(max(1, mdl%ct%nfn), rmax), &
                  this%xfac(mdl%ct%n_facets), this%flist(mdl%ct%n_facets), &
                  this%fblk(mdl%ct%n_facets), this%wxu(this%m, 0), this%xt(0, 0), this%yrow(0), &
                  this%small(0, 0), this%zs(0), &
                  this%piv(0), this%tvec(this%m), &
                  this%cx(this%m), this%cold(this%m), this%rho(this%m), this%xbase(this%m), &
                  this%xc(this%m), this%dxc(this%m), this%yc(this%m), this%tk(this%m), &
                  this%tsum(this%m), this%y0c(this%m), this%vq(size(mdl%massless_dofs)))
        this%scratch = 0.0_dp
        this%fneed = -1
        this%fac_rank = -1
        this%nxf = -1
        this%nyf = -1
        this%fresh = env_text(FRESH_VAR) == '1'          ! the Woodbury factors never reused
        this%terms_only = env_text(BASIS_VAR) == 'terms' ! the system on the terms only
        budget = default_budget(this)
        call zcache_init(this%zc, n, this%m, budget, budget)
        this%all_columns = mdl%alm%kind /= ALM_OFF
        call columns_env(this%all_columns, this%zc%budget)
        call zt_basis_init(this, mdl, budget)
        if (this%all_columns .and. this%m > 0) then
            call zcache_ensure_all(this%zc, this%lu0, mdl%stiff, this%jac0, mdl%ct%cdofs, &
                                   stat, errmsg)
            call count_lu0(this)
            if (stat /= STAT_OK) return
        end if
        ! zcache_ensure_all on an empty cache: slot l holds column l, w(:, 1:m) is W
        if (mdl%alm%kind /= ALM_OFF) call alm_newton_init(this%almn, mdl, this%zc%w(:, 1:this%m))

    contains

        !> Whether the Newmark family's M a0 = L - B(u0) has a zero right-hand side at
        !> every dof (a consistent or redistributed mass: a lumped one is not factorized,
        !> its a0 = L - B(u0) over diag(M) is left to mass_solver_start), unless A0_VAR
        !> asks for the solve.
        logical function at_rest()
            at_rest = .not. mdl%lumped .and. env_text(A0_VAR) /= 'solve'
            if (at_rest) at_rest = all(mdl%load - st%bu == 0.0_dp)
        end function at_rest
    end subroutine implicit_init

    !> The contact nodes and the arrays of Z T on the node basis (see the module header);
    !> zt_basis when Z is kept whole, the whole of Z and the basis columns fit in the
    !> default budget (so neither evicts the other; a budget set by COLUMNS_VAR is then
    !> what bounds both), the scheme is Nitsche's and ZT_VAR does not ask for the dofs.
    subroutine zt_basis_init(this, mdl, budget)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme (zc set up)
        type(model_t), intent(in) :: mdl                    !! model
        integer(i8), intent(in) :: budget                   !! the cache's budget, bytes
        integer, allocatable :: mark(:)
        integer :: nfn, nf, f, i, g
        nfn = max(1, mdl%ct%nfn)
        nf = mdl%ct%n_facets
        allocate (this%cnode(nfn, nf), this%gx(nfn, nf), this%gold(nfn, nf), &
                  this%rhog(nfn, nf), this%pdx(this%m), this%bcn(0))
        this%gx = 0.0_dp
        this%ncn = 0
        if (nf > 0 .and. mdl%ct%nfn > 0) then
            allocate (mark(maxval(mdl%ct%nodes)), this%cnf(2, nf * nfn))
            mark = 0
            do f = 1, nf
                do i = 1, nfn
                    g = mdl%ct%nodes(i, f)
                    if (mark(g) == 0) then
                        this%ncn = this%ncn + 1
                        mark(g) = this%ncn
                        this%cnf(:, this%ncn) = [f, i]
                    end if
                    this%cnode(i, f) = mark(g)
                end do
            end do
        else
            allocate (this%cnf(2, 0))
        end if
        allocate (this%tau(nf + this%ncn))
        this%tau = 0.0_dp
        this%zt_basis = this%m > 0 .and. mdl%alm%kind == ALM_OFF .and. .not. this%zc%drop &
                        .and. 8_i8 * n_of(mdl) * (this%m + nf + this%ncn) <= budget &
                        .and. env_text(ZT_VAR) /= 'dofs'
        if (this%zt_basis) call zcache_basis_init(this%zc, nf + this%ncn)
    end subroutine zt_basis_init

    !> The model's dofs as an i8.
    pure integer(i8) function n_of(mdl)
        type(model_t), intent(in) :: mdl                    !! model
        n_of = int(mdl%n_dofs, i8)
    end function n_of

    !> The column cache's budget in bytes: half the bytes of the matrices and the factor
    !> (12 per stored entry), at least BUDGET_MIN.
    pure function default_budget(this) result(budget)
        class(implicit_scheme_t), intent(in) :: this        !! scheme (J0 factorized)
        integer(i8) :: budget
        character(len=:), allocatable :: ordering
        integer(i8) :: fnnz
        call ls_factor_info(this%lu0, ordering, fnnz)
        budget = max(BUDGET_MIN, 6_i8 * (4_i8 * size(this%jac0, kind=i8) + fnnz))
    end function default_budget

    !> DYNCONTACT_CONTACT_COLUMNS: 'all' sets every (every column at set-up), a number
    !> >= 0 the budget in MB; anything else leaves both as they are.
    subroutine columns_env(every, budget)
        logical, intent(inout) :: every                     !! every column at set-up
        integer(i8), intent(inout) :: budget                !! bytes
        character(len=:), allocatable :: v
        integer :: st, mb
        v = env_text(COLUMNS_VAR)
        if (len(v) == 0) return
        if (v == 'all') then
            every = .true.
            return
        end if
        read (v, *, iostat=st) mb
        if (st == 0 .and. mb >= 0) budget = int(mb, i8) * 1024_i8**2
    end subroutine columns_env

    !> Release the factors of J0.
    subroutine implicit_free(this)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        call ls_free(this%lu0)
        call zcache_free(this%zc)
    end subroutine implicit_free

    !> The backend of the J0 factors.
    pure function implicit_solver(this) result(name)
        class(implicit_scheme_t), intent(in) :: this        !! scheme
        character(len=:), allocatable :: name
        name = trim(this%lu0%backend)
    end function implicit_solver

    !> The time step, and what a step carries into the next besides the state: M (u - u~) and u - u~ of the
    !> next step's predictor, and the contact part C on the contact-cell dofs with its
    !> tangent and the vector it was evaluated at (reused when u has not moved there).
    pure subroutine implicit_save(this, buf)
        class(implicit_scheme_t), intent(in) :: this        !! scheme
        type(byte_buffer_t), intent(inout) :: buf           !! checkpoint payload
        call buf_put(buf, this%dt)
        call buf_put(buf, this%md)
        call buf_put(buf, this%dvec)
        call buf_put(buf, int(merge(1, 0, this%cached), kind(buf%n)))
        call buf_put(buf, int(this%rank, kind(buf%n)))
        call buf_put(buf, this%xc)
        call buf_put(buf, this%cx)
        call buf_put(buf, this%ua)
        call buf_put(buf, this%vb)
        call buf_put(buf, this%qloc)
        ! the layout of the cache of columns (not its numbers: solved again at the restart)
        if (this%all_columns) then
            call buf_put(buf, 0_i8)
        else
            call buf_put(buf, 1_i8)
            call zcache_save(this%zc, buf)
        end if
    end subroutine implicit_save

    !> Read back what implicit_save wrote (buf%bad on any mismatch of sizes).
    pure subroutine implicit_load(this, buf)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme (set up by init)
        type(byte_buffer_t), intent(inout) :: buf           !! checkpoint payload
        integer(kind(buf%n)) :: k
        real(dp) :: dt
        type(zcache_t) :: skip
        call buf_get(buf, dt)
        if (.not. dt == this%dt) buf%bad = .true.
        call buf_get(buf, this%md)
        call buf_get(buf, this%dvec)
        call buf_get(buf, k)
        this%cached = k == 1
        call buf_get(buf, k)
        if (k < 0 .or. k > size(this%ua, 2)) buf%bad = .true.
        if (.not. buf%bad) this%rank = int(k)
        call buf_get(buf, this%xc)
        call buf_get(buf, this%cx)
        call buf_get(buf, this%ua)
        call buf_get(buf, this%vb)
        call buf_get(buf, this%qloc)
        ! the cache of columns: its layout, the columns solved again before the next step
        ! (restore_columns); every column kept where all were computed at set-up (here:
        ! the layout read past; there: none saved, the cache starts empty)
        call buf_get(buf, k)
        if (k < 0 .or. k > 1) buf%bad = .true.
        if (.not. buf%bad .and. k == 1) then
            if (this%all_columns) then
                call zcache_init(skip, this%zc%n, this%zc%m, 0_i8, 0_i8)
                if (allocated(this%zc%bslot)) call zcache_basis_init(skip, size(this%zc%bslot))
                call zcache_load(skip, buf)
            else
                call zcache_load(this%zc, buf)
            end if
        end if
        this%fac_rank = -1      ! (the Woodbury factors, X and Y are formed again)
        this%nxf = -1
        this%nyf = -1
        ! the terms' facets and coefficients are not in the checkpoint: the first step
        ! evaluates the contact part again at u (the same numbers as the ones saved)
        this%cached = .false.
    end subroutine implicit_load

    !> The triangular solve used with the J0 factors.
    pure function implicit_kernel(this) result(name)
        class(implicit_scheme_t), intent(in) :: this        !! scheme
        character(len=:), allocatable :: name
        name = ls_kernel(this%lu0)
    end function implicit_kernel

    !> The &solver kind applied to J0, the CG counters and the fallback note.
    pure subroutine implicit_solver_report(this, kind, solves, iterations, max_its, note)
        class(implicit_scheme_t), intent(in) :: this        !! scheme
        character(len=:), allocatable, intent(out) :: kind  !! kind requested
        integer(i8), intent(out) :: solves, iterations      !! CG solves and iterations
        integer, intent(out) :: max_its                     !! most iterations of one solve
        character(len=:), allocatable, intent(out) :: note  !! fallback note
        kind = trim(this%lu0%kind)
        call ls_cg_counts(this%lu0, solves, iterations, max_its)
        note = trim(this%lu0%note)
    end subroutine implicit_solver_report

    !> The ordering and the stored entries of the J0 factors.
    pure subroutine implicit_factor_info(this, ordering, nnz)
        class(implicit_scheme_t), intent(in) :: this        !! scheme
        character(len=:), allocatable, intent(out) :: ordering  !! ordering's name
        integer(i8), intent(out) :: nnz                     !! stored entries of the factor
        call ls_factor_info(this%lu0, ordering, nnz)
    end subroutine implicit_factor_info

    !> One step: semi-smooth Newton from x = u^n. u~ and M (u^n - u~) were formed at
    !> the end of the previous step (or in init). The first iteration solves with J0
    !> (y0 = J0^{-1} R(u^n)); after it R is zero but on the contact-cell dofs, and is
    !> updated exactly from the solve identity, R' = c (C(x') - C(x) - D dx) (C = contact
    !> part of B, D its tangent); the later iterations run on the contact-cell dofs (see
    !> the module header). The step x = u^n - dx, dx = y0 + Z T, is applied in one pass
    !> that also forms v', a' and the next predictor, then one pass over the matrix blocks
    !> forms K_theta u', M v', M (u' - u~'): a contact-free step is one solve and two
    !> passes over the vectors besides the right-hand side's.
    subroutine implicit_step(this, mdl, st, stat, errmsg)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        type(state_t), intent(inout) :: st                  !! state
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        call step_solves(this, mdl, st, stat, errmsg)
        call count_lu0(this)
    end subroutine implicit_step

    !> Add to the scheme's factorizations those of J0's factors not counted yet: the
    !> direct factorization when CG meets a curvature <= 0 and falls back to it
    !> (linear_solver's cg_fall_back, in any solve with lu0: the step's, the contact
    !> columns') is counted by the factors alone.
    pure subroutine count_lu0(this)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        this%factorizations = this%factorizations + this%lu0%factorizations - this%lu0_counted
        this%lu0_counted = this%lu0%factorizations
    end subroutine count_lu0

    !> The step of implicit_step (its solves with lu0 counted there).
    subroutine step_solves(this, mdl, st, stat, errmsg)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        type(state_t), intent(inout) :: st                  !! state
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp) :: e_pen, e_theta, f_n, cb, kb
        integer :: it, active
        logical :: flight, moved
        st%clear = .false.
        if (mdl%alm%kind /= ALM_OFF) then
            call implicit_step_alm(this, mdl, st, stat, errmsg)
            return
        end if
        stat = STAT_OK
        ! right-hand side b and R(u^n) = M (u^n - u~) + c B(u^n) - b in one pass; the
        ! convergence test's scale |M (u^n - u~)| + c |B(u^n)| + |b| is formed only when
        ! a test needs it (see newton_scale)
        call rhs_coefficients(this, cb, kb)
        call newton_rhs(size(st%u), cb, kb, this%c, mdl%load, st%bu, this%md, this%r)
        ! contact part at u^n: kept from the end of the previous step when u^n on the
        ! contact-cell dofs is the vector it was evaluated at
        active = st%active; e_pen = st%e_pen; e_theta = st%e_theta; f_n = st%f_n
        if (this%m > 0) then
            if (this%zc%restore_due) then
                call restore_columns(this, mdl, stat, errmsg)
                if (stat /= STAT_OK) return
            end if
            call zcache_new_step(this%zc)
            ! xc <- u^n there, and whether that moved it (one pass)
            call gather_moved(st%u, mdl%ct%cdofs, this%xc, moved)
            if (.not. this%cached .or. moved) then
                call contact_part(this, mdl, st%u, this%cx, active, e_pen, e_theta, f_n)
            end if
            this%tsum = 0.0_dp
            if (this%zt_basis) this%tau = 0.0_dp
            this%rhog_due = .false.
        end if
        call newton_iterate(this, mdl, st, cb, kb, it, active, e_pen, e_theta, f_n, flight, &
                            stat, errmsg)
        st%newton_its = it
        this%newton_total = this%newton_total + it
        if (stat /= STAT_OK) return
        ! dx = y0 + Z T on the rows of Z (J0^{-1} of the contact correction), on the node
        ! basis when it has fewer columns to read (see the module header)
        if (it == 0) this%dx = 0.0_dp
        if (this%m > 0 .and. .not. flight) then     ! (in flight T = 0: no Newton correction)
            if (any(this%tsum /= 0.0_dp)) then
                if (basis_pays(this)) then
                    call apply_zt_basis(this, mdl, st%t + this%dt, stat, errmsg)
                    if (stat /= STAT_OK) return
                else
                    call zcache_add_z(this%zc, this%tsum, this%dx)
                end if
            end if
        end if
        call update_state(this, mdl, st)
        st%active = active; st%e_pen = e_pen; st%e_theta = e_theta; st%f_n = f_n
        st%clear = flight       ! (u' = x on the contact-cell dofs: the probe reads it)
        st%t = st%t + this%dt
    end subroutine step_solves

    !> The basis vector b_k on the contact-cell dofs: s_f (k = f <= n_facets) or the
    !> normal n_j of contact node j (k = n_facets + j: its facet's nvec at the node, on
    !> the dofs where it is nonzero), as indices into cdofs (0: none) and entries.
    pure subroutine basis_vector(this, mdl, k, cols, coef)
        class(implicit_scheme_t), intent(in) :: this        !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        integer, intent(in) :: k                            !! basis vector
        integer, intent(out) :: cols(:)                     !! (ndof_e) its contact-cell dofs
        real(dp), intent(out) :: coef(:)                    !! (ndof_e) its entries there
        integer :: nf, f, i, kk
        nf = mdl%ct%n_facets
        if (k <= nf) then
            cols = mdl%ct%cloc(:, k)
            coef = mdl%ct%s(:, k)
        else
            f = this%cnf(1, k - nf)
            i = this%cnf(2, k - nf)
            do kk = 1, mdl%ndof_e
                cols(kk) = mdl%ct%cloc(kk, f)
                if (mdl%ct%nvec(kk, i, f) == 0.0_dp) cols(kk) = 0
            end do
            coef = mdl%ct%nvec(:, i, f)
        end if
    end subroutine basis_vector

    !> A restart's set-up, once the checkpoint is loaded and before the run's folder is
    !> written: the column cache as the checkpoint's (restore_columns), so that a stop
    !> signal during its solves (the stop flag is read before each group of columns:
    !> STAT_INTERRUPTED) leaves the folder as it was. Nothing to do without contact
    !> columns or with none to restore; a checkpoint loaded otherwise (a Stepper's load)
    !> has its columns restored before its next step.
    subroutine implicit_restore_columns(this, mdl, stat, errmsg)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme (checkpoint loaded)
        type(model_t), intent(in) :: mdl                    !! model
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        stat = STAT_OK
        if (this%m > 0 .and. this%zc%restore_due) call restore_columns(this, mdl, stat, errmsg)
    end subroutine implicit_restore_columns

    !> After a restart, before the first step: the column cache as the checkpoint's
    !> (contact_columns' zcache_restore: its groups solved again, its basis columns formed
    !> again in their slots), its solves not counted: the CG counters are put back, so
    !> that summary.json counts the solves of the run never stopped.
    subroutine restore_columns(this, mdl, stat, errmsg)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer(i8) :: solves, iterations
        integer :: max_its, s, ne, cols(MAX_E)
        real(dp) :: coef(MAX_E)
        call ls_cg_counts(this%lu0, solves, iterations, max_its)
        call zcache_restore(this%zc, this%lu0, mdl%stiff, this%jac0, mdl%ct%cdofs, stat, errmsg)
        if (stat == STAT_OK .and. allocated(this%zc%bslot)) then
            ne = mdl%ndof_e
            do s = 1, size(this%zc%bowner)
                if (this%zc%bowner(s) == 0) cycle
                call basis_vector(this, mdl, this%zc%bowner(s), cols(1:ne), coef(1:ne))
                call zcache_basis_reform(this%zc, this%lu0, mdl%stiff, this%jac0, &
                                         mdl%ct%cdofs, s, cols(1:ne), coef(1:ne), stat, errmsg)
                if (stat /= STAT_OK) exit
            end do
        end if
        if (stat == STAT_OK) call zcache_restore_finish(this%zc)
        this%lu0%cg%solves = solves
        this%lu0%cg%iterations = iterations
        this%lu0%cg%max_its = max_its
    end subroutine restore_columns

    !> Whether Z T goes on the node basis at this step: zt_basis and fewer nonzero
    !> coefficients in tau than in T.
    pure logical function basis_pays(this)
        class(implicit_scheme_t), intent(in) :: this        !! scheme
        basis_pays = .false.
        if (.not. this%zt_basis) return
        basis_pays = count(this%tau /= 0.0_dp) < count(this%tsum /= 0.0_dp)
    end function basis_pays

    !> dx <- dx + sum_k tau_k Z b_k over the vectors b_k = s_f (k = f) and n_j (k =
    !> n_facets + j) with tau_k /= 0, their columns formed first if not held (and marked
    !> used at this step); then dx = pdx (the Newton's P dx) on the contact-cell dofs.
    subroutine apply_zt_basis(this, mdl, t, stat, errmsg)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        real(dp), intent(in) :: t                           !! time the step is to reach
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: k, i, ne, cols(MAX_E)           ! (fixed size: no heap array a call)
        real(dp) :: coef(MAX_E)
        stat = STAT_OK
        ne = mdl%ndof_e
        do k = 1, size(this%tau)
            if (this%tau(k) == 0.0_dp) cycle
            if (this%zc%bslot(k) > 0) then      ! held: marked used (zcache_basis_ensure's)
                this%zc%blast(k) = this%zc%step
                cycle
            end if
            call basis_vector(this, mdl, k, cols(1:ne), coef(1:ne))
            call zcache_basis_ensure(this%zc, this%lu0, mdl%stiff, this%jac0, mdl%ct%cdofs, &
                                     k, cols(1:ne), coef(1:ne), stat, errmsg)
            if (stat /= STAT_OK) then
                call correction_failed(this, t, stat, errmsg)
                return
            end if
        end do
        call zcache_add_basis(this%zc, this%tau, this%dx)
        do i = 1, this%m
            this%dx(mdl%ct%cdofs(i)) = this%pdx(i)
        end do
    end subroutine apply_zt_basis

    !> tau <- tau + w g on the node basis, g in the facets' Mt (a vector sum_f Mt_f g(:, f),
    !> Mt_f(:, j) = theta s_f - gamma_f n_j): theta sum_j g(j, f) at s_f, -gamma_f g(j, f)
    !> at n_j.
    pure subroutine tau_add_g(this, mdl, w, g)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        real(dp), intent(in) :: w                           !! weight
        real(dp), intent(in) :: g(:, :)                     !! (nfn, n_facets) coefficients
        integer :: f
        do f = 1, mdl%ct%n_facets
            call tau_add_facet(this, mdl, f, w, g(:, f))
        end do
    end subroutine tau_add_g

    !> tau <- tau + w Mt_f g on the node basis (one facet's part of tau_add_g).
    pure subroutine tau_add_facet(this, mdl, f, w, g)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        integer, intent(in) :: f                            !! facet
        real(dp), intent(in) :: w                           !! weight
        real(dp), intent(in) :: g(:)                        !! (nfn) coefficients in Mt_f
        integer :: j, k
        real(dp) :: v
        do j = 1, mdl%ct%nfn
            v = w * g(j)
            if (v == 0.0_dp) cycle
            this%tau(f) = this%tau(f) + mdl%ct%theta * v
            k = mdl%ct%n_facets + this%cnode(j, f)
            this%tau(k) = this%tau(k) - mdl%ct%gamma(f) * v
        end do
    end subroutine tau_add_facet

    !> The coefficients of b = cb (L - kb B(u^n)) for the scheme's family.
    pure subroutine rhs_coefficients(this, cb, kb)
        class(implicit_scheme_t), intent(in) :: this        !! scheme
        real(dp), intent(out) :: cb, kb                     !! coefficients
        real(dp) :: dt
        dt = this%dt
        if (this%kind == KIND_NEWMARK) then
            kb = this%alpha_f
            cb = this%beta * dt**2 / (1.0_dp - this%alpha_m)
        else
            kb = 1.0_dp - this%theta
            cb = this%theta * dt**2
        end if
    end subroutine rhs_coefficients

    !> The Newton iterations of a step, from x = u^n (R(u^n) in this%r): the first
    !> always solves with J0 (its linear part exactly) and the test runs after it, on R
    !> at the new iterate. A zero residual passes any scale (a step in flight: no
    !> contact point active at either iterate, rho = 0 exactly), so the scale's three
    !> sums over the dofs are formed only at a step where the contact part moved R, once
    !> a step. On return dx holds y0 and tsum the coefficients T; `it` iterations;
    !> flight: the step ended in flight (contact_clear true at the iterate).
    subroutine newton_iterate(this, mdl, st, cb, kb, it, active, e_pen, e_theta, f_n, flight, &
                              stat, errmsg)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        type(state_t), intent(in) :: st                     !! state at t^n
        real(dp), intent(in) :: cb, kb                      !! coefficients of b
        integer, intent(out) :: it                          !! iterations done
        integer, intent(inout) :: active                    !! contact state at the iterate
        real(dp), intent(inout) :: e_pen, e_theta           !! contact energies at the iterate
        real(dp), intent(inout) :: f_n                      !! normal contact force at the iterate
        logical, intent(out) :: flight                      !! ended in flight (see above)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp) :: rnorm, scale, dt
        character(len=512) :: why
        logical :: warm
        integer :: l, q, nk, f
        flight = .false.
        stat = STAT_OK
        dt = this%dt
        scale = -1.0_dp
        rnorm = 0.0_dp
        it = 0
        do
            if (it > 0) then
                if (rnorm == 0.0_dp) exit
                if (scale < 0.0_dp) then
                    scale = newton_scale(this%c, cb, kb, mdl%load, this%md, st%bu)
                end if
                if (rnorm <= this%tol * scale) exit
            end if
            if (.not. (rnorm == rnorm) .or. it >= this%maxit) then
                this%failure = FAILURE_STEP
                call raise(stat, errmsg, STAT_NUMERIC, 'Newton did not converge at t = ' &
                           //real_text(st%t + dt, 6)//' after ' &
                           //counted(int(it, i8), 'iteration')//' (relative residual ' &
                           //real_text(rnorm / max(scale, tiny(1.0_dp)), 4)//')')
                return
            end if
            ! the Newton step x <- x - J^{-1} R: J^{-1} R = y + Z tk with y = J0^{-1} R on
            ! the first iteration (R is full) and y = 0 after it (R = P^T rho, so
            ! J0^{-1} R = Z rho): yc = P y, tk = 0 or rho, then Woodbury's - U s
            if (it == 0) then
                why = ''
                ! CG starts from the step the predictor with a' = a takes (see first_guess)
                warm = this%lu0%backend == BACKEND_PCG
                if (warm) call first_guess(this, st%a)
                call ls_solve(this%lu0, mdl%stiff, this%r, this%dx, stat, why, guess=warm, &
                              val=this%jac0)
                if (stat /= STAT_OK) then
                    call step_failed(this, merge(FAILURE_CG, FAILURE_STEP, this%lu0%backend == &
                                     BACKEND_PCG), 'linear solve failed in Newton', st%t + dt, &
                                     why, stat, errmsg)
                    return
                end if
                it = 1
                if (this%m == 0) exit
                ! in flight: with no contact term at u^n (rank 0: C and its coefficients
                ! are zero there) and P >= 0 at every facet's nodes at x = u^n - y0
                ! (contact_clear), C(x) is zero too and so is R at x (rho = 0): the step
                ! is done, without the passes over the contact-cell dofs (P y0, T, R')
                ! that contact_residual makes to find it. x there is the same, and so are
                ! e_theta and what a later step reads (C, its coefficients, rank 0); the
                ! rest contact_residual sets is written before it is read. x = u' on the
                ! contact-cell dofs (update_state's u - dx): the probe skips [P]_- there.
                if (this%rank == 0) then
                    do l = 1, this%m
                        this%x(mdl%ct%cdofs(l)) = st%u(mdl%ct%cdofs(l)) - this%dx(mdl%ct%cdofs(l))
                    end do
                    call contact_clear(mdl%ct, this%x, flight, e_theta)
                    if (flight) then
                        active = 0
                        e_pen = 0.0_dp
                        f_n = 0.0_dp
                        exit
                    end if
                end if
                call gather(this%dx, mdl%ct%cdofs, this%yc)
                this%y0c = this%yc
                this%tk = 0.0_dp
            else
                nk = 0
                do l = 1, this%m
                    if (this%rho(l) == 0.0_dp) cycle
                    nk = nk + 1
                    this%need(nk) = l
                end do
                call need_columns(this, mdl, nk, st%t + dt, stat, errmsg)
                if (stat /= STAT_OK) return
                call zcache_w_times(this%zc, this%rho, this%yc)
                this%tk = this%rho
                if (this%zt_basis) then
                    if (this%rhog_due) call rhog_finish(this)
                    call tau_add_g(this, mdl, 1.0_dp, this%rhog)
                end if
                it = it + 1
            end if
            if (this%rank > 0) then
                ! (a facet's terms are consecutive and on its cell's dofs: listed once; and
                ! once a step, as the columns made available at a step are held to its
                ! end: the cache drops only columns of earlier steps)
                nk = 0
                do q = 1, this%rank
                    if (q > 1) then
                        if (this%tfac(q) == this%tfac(q - 1)) cycle
                    end if
                    f = this%tfac(q)
                    if (this%fneed(f) == this%zc%step) cycle
                    this%fneed(f) = this%zc%step
                    do l = 1, mdl%ndof_e
                        if (this%qloc(l, q) <= 0) cycle
                        nk = nk + 1
                        this%need(nk) = this%qloc(l, q)
                    end do
                end do
                if (nk > 0) call need_columns(this, mdl, nk, st%t + dt, stat, errmsg)
                if (stat /= STAT_OK) return
                call woodbury(this, mdl, stat)
                if (stat /= STAT_OK) then
                    call step_failed(this, FAILURE_STEP, 'singular contact correction in ' &
                                     //'Newton', st%t + dt, '', stat, errmsg)
                    return
                end if
            end if
            this%tsum = this%tsum + this%tk
            call contact_residual(this, mdl, st%u, active, e_pen, e_theta, f_n, rnorm)
        end do
    end subroutine newton_iterate

    !> A first guess of y0 = J0^{-1} R(u^n) = u^n - x for an iterative solve, from the state
    !> alone (so a restarted run makes the same guess): the step the predictor takes when
    !> a' = a (Newmark family: x = u~ + beta dt^2 a, so dx = dvec - (k + beta dt^2) a with
    !> dvec = u - u~ + k a) or v' = v (theta: x = u~, dx = dvec). It misses y0 by
    !> beta dt^2 (a' - a), small against y0 ~ dt v for the modes the step resolves.
    pure subroutine first_guess(this, a)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme (dx set)
        real(dp), intent(in) :: a(:)                        !! acceleration a^n
        if (this%kind == KIND_NEWMARK) then
            this%dx = this%dvec - (this%kga + this%beta * this%dt**2) * a
        else
            this%dx = this%dvec
        end if
    end subroutine first_guess

    !> After a Newton correction (T in tsum): P dx = y0c + W T (the same sums, in the
    !> same order, as the full dx at the end), P x' = P u^n - P dx, dxc = P x - P x',
    !> then R' = c (C(x') - C(x) + D dx) on the contact-cell dofs (zero elsewhere: the
    !> step solved the linearization exactly), tvec = D P dx with D = U V^T at x; the
    !> contact part and its tangent are left at x'. rnorm = |R'|.
    pure subroutine contact_residual(this, mdl, u, active, e_pen, e_theta, f_n, rnorm)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        real(dp), intent(in) :: u(:)                        !! u^n
        integer, intent(out) :: active                      !! contact state at x'
        real(dp), intent(out) :: e_pen, e_theta             !! contact energies at x'
        real(dp), intent(out) :: f_n                        !! normal contact force at x'
        real(dp), intent(out) :: rnorm                      !! |R'|
        real(dp) :: acc, at(MAX_FN)
        integer :: i, q, nt
        this%dxc = this%y0c
        call zcache_add_w(this%zc, this%tsum, this%dxc)
        if (this%zt_basis) this%pdx = this%dxc
        do i = 1, this%m
            acc = u(mdl%ct%cdofs(i)) - this%dxc(i)
            this%dxc(i) = this%xc(i) - acc
            this%xc(i) = acc
            this%x(mdl%ct%cdofs(i)) = acc
        end do
        this%tvec = 0.0_dp
        if (this%zt_basis) this%rhog(:, :) = 0.0_dp
        ! the terms facet by facet (a facet's terms are consecutive, on its cell's dofs):
        ! each term's acc = v . P dx, then each dof's tvec += u acc over the facet's terms
        ! in their order (the same additions in the same order as term after term)
        q = 1
        do while (q <= this%rank)
            nt = 1
            do while (q + nt <= this%rank .and. nt < MAX_FN)
                if (this%tfac(q + nt) /= this%tfac(q)) exit
                nt = nt + 1
            end do
            call facet_tangent(mdl%ndof_e, nt, this%m, this%qloc(:, q), this%vb(:, q:q + nt - 1), &
                               this%ua(:, q:q + nt - 1), this%dxc, this%tvec, at)
            ! (the term's U column is Mt tca on its facet: tvec's coefficients in rhog)
            if (this%zt_basis) call facet_rhog(size(this%tca, 1), nt, at, &
                                               this%tca(:, q:q + nt - 1), &
                                               this%rhog(:, this%tfac(q)))
            q = q + nt
        end do
        ! (C at x kept in cold, its coefficients in gold: cx and cold, gx and gold
        ! exchanged, then cx and gx formed anew, every entry)
        call swap_c(this)
        if (this%zt_basis) call swap_g(this)
        call contact_part(this, mdl, this%x, this%cx, active, e_pen, e_theta, f_n)
        this%rho = this%c * (this%cx - this%cold + this%tvec)
        ! rhog = c (gx - gold + rhog) is formed when a next iteration reads it (rhog_finish)
        this%rhog_due = this%zt_basis
        rnorm = sqrt(sum(this%rho**2))
    end subroutine contact_residual

    !> One facet's nt terms of D P dx: at(t) = v_t . dx on the facet's dofs loc (> 0;
    !> v_t . dx summed in the order of the dofs), then tvec(loc(i)) += u_t(i) at(t) for
    !> t = 1..nt in that order (the additions of term after term, in the same order).
    !> Three terms (a compressed facet, a triangle piece) or two (a segment's points)
    !> take one pass over the dofs for their sums, each summed in its own order, and one
    !> for tvec.
    pure subroutine facet_tangent(ne, nt, m, loc, vb, ua, dxc, tvec, at)
        integer, intent(in) :: ne, nt, m                    !! cell dofs, terms, contact-cell dofs
        integer, intent(in) :: loc(ne)                      !! the terms' contact-cell dofs
        real(dp), intent(in) :: vb(ne, nt), ua(ne, nt)      !! their V and U columns
        real(dp), intent(in) :: dxc(m)                      !! P dx
        real(dp), intent(inout) :: tvec(m)                  !! D P dx (added to)
        real(dp), intent(out) :: at(nt)                     !! v_t . dx
        real(dp) :: xe(MAX_E), acc, a1, a2, a3     ! (fixed size: no heap array a call)
        integer :: i, t, l
        if (nt == 3) then
            a1 = 0.0_dp; a2 = 0.0_dp; a3 = 0.0_dp
            do i = 1, ne
                l = loc(i)
                if (l <= 0) cycle
                acc = dxc(l)
                a1 = a1 + vb(i, 1) * acc
                a2 = a2 + vb(i, 2) * acc
                a3 = a3 + vb(i, 3) * acc
            end do
            at(1) = a1; at(2) = a2; at(3) = a3
            do i = 1, ne
                l = loc(i)
                if (l <= 0) cycle
                acc = tvec(l)
                acc = acc + ua(i, 1) * a1
                acc = acc + ua(i, 2) * a2
                tvec(l) = acc + ua(i, 3) * a3
            end do
            return
        end if
        if (nt == 2) then       ! (a segment's two points: the same, for two sums)
            a1 = 0.0_dp; a2 = 0.0_dp
            do i = 1, ne
                l = loc(i)
                if (l <= 0) cycle
                acc = dxc(l)
                a1 = a1 + vb(i, 1) * acc
                a2 = a2 + vb(i, 2) * acc
            end do
            at(1) = a1; at(2) = a2
            do i = 1, ne
                l = loc(i)
                if (l <= 0) cycle
                acc = tvec(l)
                acc = acc + ua(i, 1) * a1
                tvec(l) = acc + ua(i, 2) * a2
            end do
            return
        end if
        do i = 1, ne      ! (a select, not a zeroing pass and a branch: no memset call)
            l = loc(i)
            xe(i) = merge(dxc(max(l, 1)), 0.0_dp, l > 0)
        end do
        do t = 1, nt
            acc = 0.0_dp
            do i = 1, ne
                if (loc(i) > 0) acc = acc + vb(i, t) * xe(i)
            end do
            at(t) = acc
        end do
        do i = 1, ne
            l = loc(i)
            if (l <= 0) cycle
            acc = tvec(l)
            do t = 1, nt
                acc = acc + ua(i, t) * at(t)
            end do
            tvec(l) = acc
        end do
    end subroutine facet_tangent

    !> rg <- rg + sum_t at(t) ca(:, t), t in order: the facet's tangent part of R in its Mt.
    pure subroutine facet_rhog(nfn, nt, at, ca, rg)
        integer, intent(in) :: nfn, nt                      !! facet nodes, terms
        real(dp), intent(in) :: at(nt)                      !! v_t . dx
        real(dp), intent(in) :: ca(nfn, nt)                 !! the terms' coefficients in Mt
        real(dp), intent(inout) :: rg(nfn)                  !! the facet's coefficients
        integer :: t
        if (nfn == 2 .and. nt == 2) then    ! (a segment's two points, written out)
            rg(1) = (rg(1) + at(1) * ca(1, 1)) + at(2) * ca(1, 2)
            rg(2) = (rg(2) + at(1) * ca(2, 1)) + at(2) * ca(2, 2)
            return
        end if
        do t = 1, nt
            rg = rg + at(t) * ca(:, t)
        end do
    end subroutine facet_rhog

    !> Exchange cx and cold (their allocations: no copy).
    pure subroutine swap_c(this)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        real(dp), allocatable :: tmp(:)
        call move_alloc(this%cold, tmp)
        call move_alloc(this%cx, this%cold)
        call move_alloc(tmp, this%cx)
    end subroutine swap_c

    !> Exchange gx and gold (their allocations: no copy).
    pure subroutine swap_g(this)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        real(dp), allocatable :: tmp(:, :)
        call move_alloc(this%gold, tmp)
        call move_alloc(this%gx, this%gold)
        call move_alloc(tmp, this%gx)
    end subroutine swap_g

    !> rhog = c (gx - gold + rhog): R's coefficients on the node basis at the iterate of
    !> the last contact_residual (whose tangent part it left in rhog), formed only by
    !> the iteration that uses it (none after the last).
    pure subroutine rhog_finish(this)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        integer :: f, j
        do f = 1, size(this%rhog, 2)
            do j = 1, size(this%rhog, 1)
                this%rhog(j, f) = this%c * (this%gx(j, f) - this%gold(j, f) + this%rhog(j, f))
            end do
        end do
        this%rhog_due = .false.
    end subroutine rhog_finish

    !> The columns need(1:nk) of Z and W made available for this step (solved
    !> if not held); a failed solve stops the run (STAT_NUMERIC).
    subroutine need_columns(this, mdl, nk, t, stat, errmsg)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        integer, intent(in) :: nk                           !! columns in need(1:nk)
        real(dp), intent(in) :: t                           !! time the step is to reach
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        call zcache_ensure(this%zc, this%lu0, mdl%stiff, this%jac0, mdl%ct%cdofs, &
                           this%need(1:nk), stat, errmsg)
        if (stat /= STAT_OK) call correction_failed(this, t, stat, errmsg)
    end subroutine need_columns

    !> A failed solve of the contact correction's columns of J0^{-1}: STAT_NUMERIC, with
    !> the solver's own reason (conjugate gradients: the residual reached and the &solver
    !> limits) kept after the scheme's words and t.
    pure subroutine correction_failed(this, t, stat, errmsg)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        real(dp), intent(in) :: t                           !! time the step is to reach
        integer, intent(out) :: stat                        !! STAT_NUMERIC
        character(len=*), intent(inout), optional :: errmsg !! the solver's message in, ours out
        call step_solve_failed(this, this%lu0%backend == BACKEND_PCG, 'linear solve failed '// &
                               'for the contact correction', t, stat, errmsg)
    end subroutine correction_failed

    !> The scheme's update of u, v, a from x = u - dx and the next predictor u~' in one
    !> pass; then K_theta u', M v', M (u' - u~') in one pass; B(u') = K_theta u' + C(u').
    !> Dofs without inertia (redistributed mass) are quasi-static: their v, a do not
    !> enter the dynamics (zero rows of M), and are reported as v = (u' - u)/dt, a = 0.
    !> The contact part is kept for the next step, with the vector it was evaluated at
    !> (u' on the contact-cell dofs).
    pure subroutine update_state(this, mdl, st)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        type(state_t), intent(inout) :: st                  !! state (u, v, a and products)
        real(dp) :: dt
        integer :: i, q, n
        dt = this%dt
        n = size(st%u)
        do q = 1, size(mdl%massless_dofs)
            i = mdl%massless_dofs(q)
            this%vq(q) = ((st%u(i) - this%dx(i)) - st%u(i)) / dt
        end do
        if (this%kind == KIND_NEWMARK) then
            call newmark_update(n, this%dx, 1.0_dp / (this%beta * dt**2), &
                                dt * (1.0_dp - this%gamma), dt * this%gamma, dt, &
                                dt**2 * (0.5_dp - this%beta), this%kga, &
                                st%u, st%v, st%a, this%dvec)
        else
            call theta_update(n, this%dx, 1.0_dp / (this%theta * dt), dt * (1.0_dp - this%theta), &
                              dt, st%u, st%v, this%dvec)
        end if
        do q = 1, size(mdl%massless_dofs)
            i = mdl%massless_dofs(q)
            st%v(i) = this%vq(q)
            if (this%kind == KIND_NEWMARK) st%a(i) = 0.0_dp
        end do
        if (size(mdl%massless_dofs) > 0) call form_predictor(this, st%u, st%v, st%a, &
                                                             mdl%massless_dofs)
        call model_step_products(mdl, st%u, st%v, this%dvec, st%ktu, st%mv, this%md, st%bu)
        if (this%m > 0) then
            do i = 1, this%m
                st%bu(mdl%ct%cdofs(i)) = st%bu(mdl%ct%cdofs(i)) + this%cx(i)
            end do
            call gather(st%u, mdl%ct%cdofs, this%xc)
            this%cached = .true.
        end if
    end subroutine update_state

    !> Contact part C(xx) of B on the contact-cell dofs, its tangent in low-rank
    !> form (rank, ua, vb, qloc), the contact energy parts and the normal contact force.
    pure subroutine contact_part(this, mdl, xx, cvec, act, ep, et, fn)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme (tangent, scratch)
        type(model_t), intent(in) :: mdl                    !! model
        real(dp), intent(in) :: xx(:)                       !! displacement
        real(dp), intent(out) :: cvec(:)                    !! (m) C(xx) on the contact-cell dofs
        integer, intent(out) :: act                         !! active contact quadrature points
        real(dp), intent(out) :: ep, et                     !! contact energy parts
        real(dp), intent(out) :: fn                         !! int [P]_- (contact_eval's f_n)
        integer :: j
        do j = 1, this%m
            this%scratch(mdl%ct%cdofs(j)) = 0.0_dp
        end do
        call contact_eval(mdl%ct, xx, this%scratch, act, ep, et, this%rank, this%ua, this%vb, &
                          this%qloc, this%tfac, this%tca, this%tcb, this%gx, fn)
        do j = 1, this%m
            cvec(j) = this%scratch(mdl%ct%cdofs(j))
        end do
    end subroutine contact_part

    !> Woodbury for one Newton step, on the contact-cell dofs: with yc = P J0^{-1} R,
    !> J^{-1} R = J0^{-1} R - Z U (I + c V^T W U)^{-1} c V^T yc, so tk <- tk - U s,
    !> s = (I + c V^T W U)^{-1} c V^T yc. The system is formed and factorized only when
    !> the tangent differs from the one of the factors held (see the module header).
    pure subroutine woodbury(this, mdl, st2)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        integer, intent(out) :: st2                         !! STAT_NUMERIC: singular system
        integer :: r, i, j, info
        logical :: nodes
        st2 = STAT_OK
        r = this%rank
        if (r > size(this%small, 1)) call grow_woodbury(this, r)
        nodes = .false.
        if (.not. this%terms_only) then
            call node_basis(this, mdl)
            nodes = this%nq < r
        end if
        if (.not. same_tangent(this, nodes)) then
            if (nodes) then
                call node_factor(this, mdl, info)
            else
                call woodbury_factor(this, mdl, info)
            end if
            if (info /= 0) then
                st2 = STAT_NUMERIC
                return
            end if
        end if
        if (nodes) then
            call node_solve(this, mdl)
            return
        end if
        ! zs = c V^T yc (each term's sum in the order of its dofs, by the explicit-shape
        ! kernels: no indexing of the scheme's components at each dof)
        ! (a 2D cell's E_2D dofs given as the constant: the kernels' loops unrolled)
        do i = 1, r
            if (mdl%ndof_e == E_2D) then
                this%zs(i) = this%c * cell_dot(E_2D, this%qloc(:, i), this%vb(:, i), &
                                               this%m, this%yc)
            else
                this%zs(i) = this%c * cell_dot(mdl%ndof_e, this%qloc(:, i), this%vb(:, i), &
                                               this%m, this%yc)
            end if
        end do
        call dense_lu_solve(r, this%small, this%piv, this%zs)
        ! tk = tk - U s
        do j = 1, r
            if (mdl%ndof_e == E_2D) then
                call cell_sub(E_2D, this%qloc(:, j), this%ua(:, j), this%zs(j), this%m, &
                              this%tk)
            else
                call cell_sub(mdl%ndof_e, this%qloc(:, j), this%ua(:, j), this%zs(j), &
                              this%m, this%tk)
            end if
        end do
        ! and on the node basis (U's column j is Mt tca(:, j) on its facet)
        if (this%zt_basis) then
            do j = 1, r
                call tau_add_facet(this, mdl, this%tfac(j), -this%zs(j), this%tca(:, j))
            end do
        end if
    end subroutine woodbury

    !> Whether the factors held are those of the current tangent: the same basis, rank,
    !> terms' facets and coefficients tca, tcb, bit for bit (never with fresh set). The
    !> system is formed from these alone (woodbury_factor: X of the terms' facets and
    !> the coefficients; node_factor: Y of the basis the facets give and the
    !> coefficients), so the same ones give the same factors to the bit; U, V and their
    !> dofs need no comparison (each term's are its facet's Mt ca, M cb).
    pure logical function same_tangent(this, nodes) result(same)
        class(implicit_scheme_t), intent(in) :: this        !! scheme
        logical, intent(in) :: nodes                        !! the system on the node basis
        integer :: j, i, nfn
        same = .false.
        if (this%fresh .or. this%fac_rank /= this%rank) return
        if (this%fac_nodes .neqv. nodes) return
        nfn = size(this%tca, 1)
        do j = 1, this%rank
            if (this%tfac(j) /= this%fac_tfac(j)) return
            do i = 1, nfn
                if (this%tca(i, j) /= this%fac_tca(i, j)) return
                if (this%tcb(i, j) /= this%fac_tcb(i, j)) return
            end do
        end do
        same = .true.
    end function same_tangent

    !> Form the Woodbury system I + c V^T W U of the current tangent and factorize it
    !> (info as dense_lu_factor's); on success the tangent is copied as the factors'.
    !> Each term of the tangent is u = Mt ca, v = M cb on its facet (nitsche_facet), so
    !> the entry (i, j) of V^T W U is cb_i^T X(f_i, f_j) ca_j with X = M^T W Mt over the
    !> facets (facets_x): r^2 nfn + r k nfn operations instead of r^2 ndof_e + m r ndof_e
    !> with U, V themselves. The same system to round-off (the facet shape values sum to
    !> 1), used with the U and V of the terms for the rest of the Newton step.
    pure subroutine woodbury_factor(this, mdl, info)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        integer, intent(out) :: info                        !! 0 or the first zero pivot
        integer :: r, k, nfn
        r = this%rank
        this%fac_rank = -1
        ! V^T W U from X = M^T W Mt over the facets with terms (each term is
        ! Mt ca, M cb of its facet): X is formed again only when those facets change
        call facets_x(this, mdl)
        nfn = mdl%ct%nfn
        k = nfn * this%nxf
        if (nfn == 2) then      ! (segments: the sums of two written out, the same order)
            call segment_system(r, k, this%c, this%tfac, this%fblk, this%tca, this%tcb, &
                                this%xt, this%yrow, this%small)
        else
            call facet_system(this, r, nfn, k)
        end if
        call dense_lu_factor(r, this%small, this%piv, info)
        if (info /= 0) return
        call keep_tangent(this, .false.)
    end subroutine woodbury_factor

    !> woodbury_factor's system I + c V^T W U for any nfn (X of the terms' facets in xt).
    pure subroutine facet_system(this, r, nfn, k)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme (small, yrow set)
        integer, intent(in) :: r, nfn, k                    !! terms, facet nodes, rows of X
        integer :: i, j, l, i0, j0
        real(dp) :: acc
        do i = 1, r
            ! yrow = cb_i^T (rows of X of the facet of term i)
            i0 = nfn * (this%fblk(this%tfac(i)) - 1)
            this%yrow(1:k) = 0.0_dp
            do j = 1, nfn
                this%yrow(1:k) = this%yrow(1:k) + this%tcb(j, i) * this%xt(1:k, i0 + j)
            end do
            do j = 1, r
                j0 = nfn * (this%fblk(this%tfac(j)) - 1)
                acc = 0.0_dp
                do l = 1, nfn
                    acc = acc + this%yrow(j0 + l) * this%tca(l, j)
                end do
                this%small(i, j) = this%c * acc
            end do
            this%small(i, i) = this%small(i, i) + 1.0_dp
        end do
    end subroutine facet_system

    !> woodbury_factor's system I + c V^T W U on segment facets (nfn = 2): row i is
    !> yrow = cb_i^T X(f_i, :) (two columns of xt: 0 + cb_1 x_1, then + cb_2 x_2), entry
    !> (i, j) c (yrow(j0 + 1) ca_1j + yrow(j0 + 2) ca_2j) summed from 0, j0 the block of
    !> term j's facet: woodbury_factor's loops over nfn written out (the same operations
    !> in the same order; explicit shapes, no zeroing pass).
    pure subroutine segment_system(r, k, c, tfac, fblk, tca, tcb, xt, yrow, small)
        integer, intent(in) :: r                            !! terms
        integer, intent(in) :: k                            !! rows of X in use (2 a facet)
        real(dp), intent(in) :: c                           !! the scheme's c
        integer, intent(in) :: tfac(:)                      !! (>= r) each term's facet
        integer, intent(in) :: fblk(:)                      !! (facets) block of a facet in X
        real(dp), intent(in) :: tca(:, :), tcb(:, :)        !! (2, >= r) the coefficients
        real(dp), intent(in) :: xt(:, :)                    !! (>= k, >= k) X transposed
        real(dp), intent(inout) :: yrow(:)                  !! (>= k) scratch
        real(dp), intent(inout) :: small(:, :)              !! (>= r, >= r) the system
        integer :: i, j, i0, j0, l
        real(dp) :: b1, b2
        do i = 1, r
            i0 = 2 * (fblk(tfac(i)) - 1)
            b1 = tcb(1, i)
            b2 = tcb(2, i)
            do l = 1, k
                yrow(l) = (0.0_dp + b1 * xt(l, i0 + 1)) + b2 * xt(l, i0 + 2)
            end do
            do j = 1, r
                j0 = 2 * (fblk(tfac(j)) - 1)
                small(i, j) = c * ((0.0_dp + yrow(j0 + 1) * tca(1, j)) &
                                   + yrow(j0 + 2) * tca(2, j))
            end do
            small(i, i) = small(i, i) + 1.0_dp
        end do
    end subroutine segment_system

    !> The tangent of the factors just formed, kept to recognize it (same_tangent).
    pure subroutine keep_tangent(this, nodes)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        logical, intent(in) :: nodes                        !! the node basis' factors
        integer :: r
        r = this%rank
        this%fac_rank = r
        this%fac_nodes = nodes
        this%fac_tfac(1:r) = this%tfac(1:r)
        ! (the leading columns as one run of nfn r values: tca and fac_tca have the same
        ! leading dimension)
        call copy_values(size(this%tca, 1) * r, this%tca, this%fac_tca)
        call copy_values(size(this%tcb, 1) * r, this%tcb, this%fac_tcb)
    end subroutine keep_tangent

    !> b(1:k) = a(1:k): a plain copy of the first k values of two arrays.
    pure subroutine copy_values(k, a, b)
        integer, intent(in) :: k                            !! values
        real(dp), intent(in) :: a(k)                        !! source
        real(dp), intent(inout) :: b(k)                     !! copy
        b = a
    end subroutine copy_values

    !> The facets of the current terms (in order; a facet's terms are consecutive) in
    !> flist, and X = M^T W Mt over them (blocks of nfn x nfn, facet by facet: M(:, j) =
    !> s - gamma nvec(:, j), Mt(:, j) = theta s - gamma nvec(:, j) on the facet's cell
    !> dofs) in xt (transposed), formed when the facets differ from those of the X held
    !> (X depends on them alone) or with fresh set; fblk(f) = the block of facet f.
    pure subroutine facets_x(this, mdl)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        integer :: nf, f, b, i, j, k, kk, l, col, row, nfn, ne, kc
        real(dp) :: acc, coef
        call term_facets(this, nf)
        if (.not. this%fresh .and. this%nxf == nf) then
            if (all(this%xfac(1:nf) == this%flist(1:nf))) return
        end if
        nfn = mdl%ct%nfn
        ne = mdl%ndof_e
        k = nfn * nf
        if (k > size(this%xt, 1)) then     ! (doubled at least, as grow_woodbury)
            kc = max(k, 2 * size(this%xt, 1))
            deallocate (this%wxu, this%xt, this%yrow)
            allocate (this%wxu(this%m, kc), this%xt(kc, kc), this%yrow(kc))
        end if
        this%nxf = nf
        this%xfac(1:nf) = this%flist(1:nf)
        do b = 1, nf
            f = this%xfac(b)
            this%fblk(f) = b
            do i = 1, nfn
                col = nfn * (b - 1) + i
                this%wxu(:, col) = 0.0_dp
                do kk = 1, ne
                    l = mdl%ct%cloc(kk, f)
                    if (l <= 0) cycle
                    coef = mdl%ct%theta * mdl%ct%s(kk, f) - mdl%ct%gamma(f) * mdl%ct%nvec(kk, i, f)
                    this%wxu(:, col) = this%wxu(:, col) + coef * this%zc%w(:, this%zc%slot(l))
                end do
            end do
        end do
        do b = 1, nf
            f = this%xfac(b)
            do j = 1, nfn
                row = nfn * (b - 1) + j
                do col = 1, k
                    acc = 0.0_dp
                    do kk = 1, ne
                        l = mdl%ct%cloc(kk, f)
                        if (l > 0) acc = acc + (mdl%ct%s(kk, f) - mdl%ct%gamma(f) &
                                                * mdl%ct%nvec(kk, j, f)) * this%wxu(l, col)
                    end do
                    this%xt(col, row) = acc
                end do
            end do
        end do
    end subroutine facets_x

    !> The facets of the current terms, in order (a facet's terms are consecutive), in
    !> flist(1:nf).
    pure subroutine term_facets(this, nf)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        integer, intent(out) :: nf                          !! facets
        integer :: t, f
        nf = 0
        do t = 1, this%rank
            f = this%tfac(t)
            if (nf > 0) then
                if (this%flist(nf) == f) cycle
            end if
            nf = nf + 1
            this%flist(nf) = f
        end do
    end subroutine term_facets

    !> The node basis of the current terms: every column of a facet's M and Mt is
    !> s_f - gamma_f n_j or theta s_f - gamma_f n_j, where s_f (sigma_n of the facet's
    !> cell) is the facet's own and n_j (the obstacle's normal on the dofs of node j, the
    !> same vector for every facet of the node: one normal) the node's, so the tangent
    !> D = sum_t u_t v_t^T = B H B^T with B = [s_f of each facet, n_j of each facet
    !> node], nq = facets + nodes columns (fewer than 3 a facet when the facets share
    !> nodes). qnode(0, f) is the basis index of facet f, qnode(i, f) that of its node
    !> i; formed when the facets differ from those of the basis held (or with fresh
    !> set), and Y = B^T W B is then formed again (node_factor).
    pure subroutine node_basis(this, mdl)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        integer :: nf, nfn, ne, b, f, i, j, g, nk, kk, e, cap
        call term_facets(this, nf)
        if (.not. this%fresh .and. this%nyf == nf) then
            if (all(this%yfac(1:nf) == this%flist(1:nf))) return
        end if
        nfn = mdl%ct%nfn
        ne = mdl%ndof_e
        if (nf * nfn > size(this%bnode)) then
            cap = max(nf * nfn, 2 * size(this%bnode))
            deallocate (this%bnode, this%bcn, this%nrow, this%nval)
            allocate (this%bnode(cap), this%bcn(cap), this%nrow(nfn, cap), this%nval(nfn, cap))
        end if
        nk = 0
        do b = 1, nf
            f = this%flist(b)
            this%yfac(b) = f
            this%qnode(0, f) = b
            do i = 1, nfn
                g = mdl%ct%nodes(i, f)
                j = 0
                do kk = 1, nk
                    if (this%bnode(kk) == g) then
                        j = kk
                        exit
                    end if
                end do
                if (j == 0) then
                    nk = nk + 1
                    j = nk
                    this%bnode(j) = g
                    this%bcn(j) = this%cnode(i, f)
                    this%nrow(:, j) = 0
                    this%nval(:, j) = 0.0_dp
                    e = 0
                    do kk = 1, ne
                        if (mdl%ct%cloc(kk, f) <= 0 .or. mdl%ct%nvec(kk, i, f) == 0.0_dp) cycle
                        e = e + 1
                        this%nrow(e, j) = mdl%ct%cloc(kk, f)
                        this%nval(e, j) = mdl%ct%nvec(kk, i, f)
                    end do
                end if
                this%qnode(i, f) = nf + j
            end do
        end do
        this%nyf = nf
        this%nq = nf + nk
        this%ybas_ok = .false.
    end subroutine node_basis

    !> Y = B^T W B over the node basis (node_basis), in ybas.
    pure subroutine form_y(this, mdl)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        integer :: q, nf, a, b, f, kk, e, l, cap
        real(dp) :: acc
        q = this%nq
        nf = this%nyf
        if (q > size(this%ybas, 1)) then     ! (doubled at least, as grow_woodbury)
            cap = max(q, 2 * size(this%ybas, 1))
            deallocate (this%wb, this%ybas, this%qa, this%qs)
            allocate (this%wb(this%m, cap), this%ybas(cap, cap), this%qa(cap), this%qs(cap))
        end if
        do b = 1, q
            this%wb(:, b) = 0.0_dp
            if (b <= nf) then
                f = this%yfac(b)
                do kk = 1, mdl%ndof_e
                    l = mdl%ct%cloc(kk, f)
                    if (l <= 0) cycle
                    this%wb(:, b) = this%wb(:, b) + mdl%ct%s(kk, f) * this%zc%w(:, this%zc%slot(l))
                end do
            else
                do e = 1, mdl%ct%nfn
                    l = this%nrow(e, b - nf)
                    if (l <= 0) cycle
                    this%wb(:, b) = this%wb(:, b) + this%nval(e, b - nf) * this%zc%w(:, this%zc%slot(l))
                end do
            end if
        end do
        do b = 1, q
            do a = 1, q
                acc = 0.0_dp
                if (a <= nf) then
                    f = this%yfac(a)
                    acc = cell_dot(mdl%ndof_e, mdl%ct%cloc(:, f), mdl%ct%s(:, f), this%m, &
                                   this%wb(:, b))
                else
                    do e = 1, mdl%ct%nfn
                        l = this%nrow(e, a - nf)
                        if (l > 0) acc = acc + this%nval(e, a - nf) * this%wb(l, b)
                    end do
                end if
                this%ybas(a, b) = acc
            end do
        end do
        this%ybas_ok = .true.
    end subroutine form_y

    !> A term's coefficients in the node basis: u_t = B alpha, v_t = B beta, with alpha
    !> = theta (sum ca) at the facet (alpha(0)) and -gamma_f ca(i) at its node i
    !> (alpha(i)); beta the same from cb, with 1 for theta.
    pure subroutine term_coefficients(nfn, ct_theta, gamma, ca, cb, alpha, beta)
        integer, intent(in) :: nfn                          !! facet nodes
        real(dp), intent(in) :: ct_theta, gamma             !! theta, gamma_f
        real(dp), intent(in) :: ca(nfn), cb(nfn)            !! the term's coefficients
        real(dp), intent(out) :: alpha(0:nfn), beta(0:nfn)  !! at the facet, then its nodes
        if (nfn == 3) then      ! (written out: sum's additions from 0, in order)
            alpha(0) = ct_theta * (((0.0_dp + ca(1)) + ca(2)) + ca(3))
            beta(0) = ((0.0_dp + cb(1)) + cb(2)) + cb(3)
            alpha(1) = -gamma * ca(1); alpha(2) = -gamma * ca(2); alpha(3) = -gamma * ca(3)
            beta(1) = -gamma * cb(1); beta(2) = -gamma * cb(2); beta(3) = -gamma * cb(3)
            return
        end if
        alpha(0) = ct_theta * sum(ca)
        beta(0) = sum(cb)
        alpha(1:nfn) = -gamma * ca
        beta(1:nfn) = -gamma * cb
    end subroutine term_coefficients

    !> The Woodbury system on the node basis, I + c Y H with H = sum_t alpha_t beta_t^T
    !> (J^{-1} = J0^{-1} - Z B H (I + c Y H)^{-1} c B^T P J0^{-1}: the Woodbury identity
    !> with U = B H, V = B), factorized (info as dense_lu_factor's); Y is formed when
    !> the basis changed. The columns of c Y H are sums over the terms of
    !> c (Y alpha_t) beta_t^T, 2 (nfn + 1) columns of Y read a term. The terms' alpha_t,
    !> beta_t are kept with the factors (halpha, hbeta): node_solve, which runs with the
    !> factors of the current tangent only (the same tfac, tca, tcb bit for bit), reads
    !> them instead of forming them again.
    pure subroutine node_factor(this, mdl, info)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        integer, intent(out) :: info                        !! 0 or the first zero pivot
        integer :: q, t, f, i, nfn, fb
        real(dp) :: a0, b0, ai(MAX_FN), bi(MAX_FN)   ! (fixed size: no heap array a call)
        this%fac_rank = -1
        if (.not. this%ybas_ok .or. this%fresh) call form_y(this, mdl)
        q = this%nq
        nfn = mdl%ct%nfn
        this%small(1:q, 1:q) = 0.0_dp
        do t = 1, this%rank
            f = this%tfac(t)
            fb = this%qnode(0, f)
            call term_coefficients(nfn, real(mdl%ct%theta, dp), mdl%ct%gamma(f), &
                                   this%tca(1:nfn, t), this%tcb(1:nfn, t), &
                                   this%halpha(0:nfn, t), this%hbeta(0:nfn, t))
            if (nfn == 3) then      ! (one pass over the rows: see term_columns3)
                associate (y => this%ybas, sm => this%small, qn => this%qnode)
                    call term_columns3(q, y(:, fb), y(:, qn(1, f)), y(:, qn(2, f)), &
                                       y(:, qn(3, f)), this%halpha(0:3, t), this%c, &
                                       this%hbeta(0:3, t), sm(:, fb), sm(:, qn(1, f)), &
                                       sm(:, qn(2, f)), sm(:, qn(3, f)))
                end associate
                cycle
            end if
            a0 = this%halpha(0, t)
            ai(1:nfn) = this%halpha(1:nfn, t)
            b0 = this%hbeta(0, t)
            bi(1:nfn) = this%hbeta(1:nfn, t)
            this%qa(1:q) = a0 * this%ybas(1:q, fb)
            do i = 1, nfn
                this%qa(1:q) = this%qa(1:q) + ai(i) * this%ybas(1:q, this%qnode(i, f))
            end do
            this%small(1:q, fb) = this%small(1:q, fb) + (this%c * b0) * this%qa(1:q)
            do i = 1, nfn
                this%small(1:q, this%qnode(i, f)) = this%small(1:q, this%qnode(i, f)) &
                                                    + (this%c * bi(i)) * this%qa(1:q)
            end do
        end do
        do i = 1, q
            this%small(i, i) = this%small(i, i) + 1.0_dp
        end do
        call dense_lu_factor(q, this%small, this%piv, info)
        if (info /= 0) return
        call keep_tangent(this, .true.)
    end subroutine node_factor

    !> One term's part of c Y H on a triangle facet (node_factor): qa = a(0) y1 + a(1) y2
    !> + a(2) y3 + a(3) y4 (Y alpha_t: the columns of the facet and its three nodes),
    !> then s_k <- s_k + (c b(k - 1)) qa on the same four columns of the system, row by
    !> row in one pass: each entry the same operations in the same order as the column
    !> loops of the general case (qa formed, then added to each column), without storing
    !> qa and reading it four times.
    pure subroutine term_columns3(q, y1, y2, y3, y4, a, c, b, s1, s2, s3, s4)
        integer, intent(in) :: q                            !! order of the system
        real(dp), intent(in) :: y1(q), y2(q), y3(q), y4(q)  !! columns of Y
        real(dp), intent(in) :: a(0:3)                      !! alpha_t
        real(dp), intent(in) :: c                           !! the coefficient c
        real(dp), intent(in) :: b(0:3)                      !! beta_t
        real(dp), intent(inout) :: s1(q), s2(q), s3(q), s4(q) !! columns of the system
        real(dp) :: x, b1, b2, b3, b4
        integer :: r
        b1 = c * b(0); b2 = c * b(1); b3 = c * b(2); b4 = c * b(3)
        do r = 1, q
            x = a(0) * y1(r)
            x = x + a(1) * y2(r)
            x = x + a(2) * y3(r)
            x = x + a(3) * y4(r)
            s1(r) = s1(r) + b1 * x
            s2(r) = s2(r) + b2 * x
            s3(r) = s3(r) + b3 * x
            s4(r) = s4(r) + b4 * x
        end do
    end subroutine term_columns3

    !> The Woodbury step on the node basis: s = (I + c Y H)^{-1} c B^T yc, then
    !> tk <- tk - B (H s).
    pure subroutine node_solve(this, mdl)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        integer :: q, nf, b, f, kk, e, l, t, i, nfn, fb
        real(dp) :: acc
        q = this%nq
        nf = this%nyf
        nfn = mdl%ct%nfn
        do b = 1, q
            acc = 0.0_dp
            if (b <= nf) then
                f = this%yfac(b)
                acc = cell_dot(mdl%ndof_e, mdl%ct%cloc(:, f), mdl%ct%s(:, f), this%m, this%yc)
            else
                do e = 1, nfn
                    l = this%nrow(e, b - nf)
                    if (l > 0) acc = acc + this%nval(e, b - nf) * this%yc(l)
                end do
            end if
            this%zs(b) = this%c * acc
        end do
        call dense_lu_solve(q, this%small, this%piv, this%zs)
        ! qs = H s = sum_t alpha_t (beta_t . s), alpha_t and beta_t kept by node_factor
        this%qs(1:q) = 0.0_dp
        do t = 1, this%rank
            f = this%tfac(t)
            fb = this%qnode(0, f)
            acc = this%hbeta(0, t) * this%zs(fb)
            do i = 1, nfn
                acc = acc + this%hbeta(i, t) * this%zs(this%qnode(i, f))
            end do
            this%qs(fb) = this%qs(fb) + this%halpha(0, t) * acc
            do i = 1, nfn
                this%qs(this%qnode(i, f)) = this%qs(this%qnode(i, f)) + this%halpha(i, t) * acc
            end do
        end do
        ! tk = tk - B qs
        do b = 1, q
            if (b <= nf) then
                f = this%yfac(b)
                call cell_sub(mdl%ndof_e, mdl%ct%cloc(:, f), mdl%ct%s(:, f), this%qs(b), &
                              this%m, this%tk)
            else
                do e = 1, nfn
                    l = this%nrow(e, b - nf)
                    if (l > 0) this%tk(l) = this%tk(l) - this%nval(e, b - nf) * this%qs(b)
                end do
            end if
        end do
        ! and on the node basis of Z T (tau: the facets, then the contact nodes)
        if (this%zt_basis) then
            do b = 1, q
                if (b <= nf) then
                    kk = this%yfac(b)
                else
                    kk = mdl%ct%n_facets + this%bcn(b - nf)
                end if
                this%tau(kk) = this%tau(kk) - this%qs(b)
            end do
        end if
    end subroutine node_solve

    !> sum over the cell's dofs with loc(k) > 0 of s(k) y(loc(k)), from 0 in the order of
    !> the dofs (a facet's sigma_n row against a vector on the contact-cell dofs; explicit
    !> shapes: a tight loop, not the contact type's components indexed at each dof).
    pure real(dp) function cell_dot(ne, loc, s, m, y) result(acc)
        integer, intent(in) :: ne                           !! cell dofs
        integer, intent(in) :: loc(ne)                      !! their contact-cell dofs (0: none)
        real(dp), intent(in) :: s(ne)                       !! the row
        integer, intent(in) :: m                            !! contact-cell dofs
        real(dp), intent(in) :: y(m)                        !! the vector
        integer :: k, l
        acc = 0.0_dp
        do k = 1, ne
            l = loc(k)
            if (l > 0) acc = acc + s(k) * y(l)
        end do
    end function cell_dot

    !> y(loc(k)) <- y(loc(k)) - s(k) alpha over the cell's dofs with loc(k) > 0, in their
    !> order.
    pure subroutine cell_sub(ne, loc, s, alpha, m, y)
        integer, intent(in) :: ne                           !! cell dofs
        integer, intent(in) :: loc(ne)                      !! their contact-cell dofs (0: none)
        real(dp), intent(in) :: s(ne)                       !! the row
        real(dp), intent(in) :: alpha                       !! its coefficient
        integer, intent(in) :: m                            !! contact-cell dofs
        real(dp), intent(inout) :: y(m)                     !! the vector (updated)
        integer :: k, l
        do k = 1, ne
            l = loc(k)
            if (l > 0) y(l) = y(l) - s(k) * alpha
        end do
    end subroutine cell_sub

    !> The Woodbury work arrays for rank r: their size follows the largest rank met (at
    !> least doubled when it grows: few reallocations, and the pages beyond the leading
    !> r x r block are never touched), not the number of contact quadrature points of
    !> Gamma_C (rmax^2 reals for the system alone: 128 MB on the ball's 4 000 points).
    pure subroutine grow_woodbury(this, r)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        integer, intent(in) :: r                            !! rank needed
        integer :: cap
        cap = min(size(this%ua, 2), max(r, 2 * size(this%small, 1), 16))
        deallocate (this%small, this%zs, this%piv)
        this%fac_rank = -1
        allocate (this%small(cap, cap), this%zs(cap), this%piv(cap))
    end subroutine grow_woodbury

    !> y(i) = u(idx(i)): a vector on the contact-cell dofs.
    pure subroutine gather(u, idx, y)
        real(dp), intent(in) :: u(:)                        !! vector
        integer, intent(in) :: idx(:)                       !! dofs
        real(dp), intent(out) :: y(:)                       !! (size(idx)) its values there
        integer :: i
        do i = 1, size(idx)
            y(i) = u(idx(i))
        end do
    end subroutine gather

    !> One step with the augmented Lagrangian (module alm_newton): R(u^n, lambda^n) with
    !> B(u^n) = K u^n - N lambda^n, the first solve y0 = J0^{-1} R, Newton on the
    !> contact-cell dofs and the multipliers, x = u^n - y0 - Z T, then the scheme's update
    !> (update_state, with C = -N lambda' in cx); B(u') = K u' - N lambda'.
    subroutine implicit_step_alm(this, mdl, st, stat, errmsg)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme
        type(model_t), intent(in) :: mdl                    !! model
        type(state_t), intent(inout) :: st                  !! state (with st%lam)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp) :: cb, kb
        integer :: it, active
        character(len=512) :: why
        stat = STAT_OK
        call rhs_coefficients(this, cb, kb)
        call newton_rhs(size(st%u), cb, kb, this%c, mdl%load, st%bu, this%md, this%r)
        why = ''
        call ls_solve(this%lu0, mdl%stiff, this%r, this%dx, stat, why, val=this%jac0)
        if (stat /= STAT_OK) then
            call step_failed(this, merge(FAILURE_CG, FAILURE_STEP, this%lu0%backend == &
                             BACKEND_PCG), 'linear solve failed in Newton', st%t + this%dt, &
                             why, stat, errmsg)
            st%newton_its = 1
            return
        end if
        call gather(st%u, mdl%ct%cdofs, this%xc)
        call gather(this%dx, mdl%ct%cdofs, this%y0c)
        call alm_newton_solve(this%almn, mdl, this%c, this%tol, this%maxit, st%t + this%dt, &
                              this%xc, this%y0c, st%lam, this%tsum, this%cx, active, it, &
                              stat, errmsg)
        st%newton_its = it
        this%newton_total = this%newton_total + it
        if (stat /= STAT_OK) then     ! (alm_newton_solve's message gives t)
            this%failure = FAILURE_STEP
            return
        end if
        if (any(this%tsum /= 0.0_dp)) call zcache_add_z(this%zc, this%tsum, this%dx)
        call update_state(this, mdl, st)
        st%active = active; st%e_pen = 0.0_dp; st%e_theta = 0.0_dp
        st%f_n = alm_resultant(mdl%alm, st%lam)
        st%t = st%t + this%dt
    end subroutine implicit_step_alm

    !> xc <- u on the dofs idx, and whether that changed a value of xc (no temporary array).
    pure subroutine gather_moved(u, idx, xc, moved)
        real(dp), intent(in) :: u(:)                        !! vector
        integer, intent(in) :: idx(:)                       !! dofs
        real(dp), intent(inout) :: xc(:)                    !! (size(idx)) values compared, then u's
        logical, intent(out) :: moved                       !! some u(idx(i)) /= xc(i)
        integer :: i
        moved = .false.
        do i = 1, size(idx)
            if (u(idx(i)) /= xc(i)) moved = .true.
            xc(i) = u(idx(i))
        end do
    end subroutine gather_moved

    !> The Newton initial residual: r = md + c bu - b with b = newton_b(cb, kb, load, bu),
    !> in one pass (b itself is formed only for the test's scale).
    pure subroutine newton_rhs(n, cb, kb, c, load, bu, md, r)
        integer, intent(in) :: n                            !! size
        real(dp), intent(in) :: cb, kb, c                   !! coefficients
        real(dp), intent(in) :: load(n), bu(n), md(n)       !! L, B(u^n), M (u^n - u~)
        real(dp), intent(out) :: r(n)                       !! R(u^n)
        integer :: k
        do k = 1, n
            r(k) = md(k) + c * bu(k) - newton_b(cb, kb, load(k), bu(k))
        end do
    end subroutine newton_rhs

    !> b = cb (L - kb B(u^n)), the load part of the step's residual.
    elemental real(dp) function newton_b(cb, kb, load, bu) result(b)
        real(dp), intent(in) :: cb, kb                      !! coefficients
        real(dp), intent(in) :: load, bu                    !! L and B(u^n) at one dof
        b = cb * (load - kb * bu)
    end function newton_b

    !> The scale of the Newton test, |md| + c |bu| + |b| (the norms of the three terms of
    !> R(u^n) = md + c bu - b), each sum of squares a `dot` (LANES partial sums: one
    !> reduction a loop is what the compiler vectorizes cleanly; several in one loop it
    !> interleaves with shuffles); b = newton_b(cb, kb, load, bu) is not formed (b_dot).
    pure real(dp) function newton_scale(c, cb, kb, load, md, bu) result(scale)
        real(dp), intent(in) :: c                           !! coefficient of B in R
        real(dp), intent(in) :: cb, kb                      !! coefficients of b
        real(dp), intent(in), contiguous :: load(:)         !! L
        real(dp), intent(in), contiguous :: md(:)           !! M (u^n - u~)
        real(dp), intent(in), contiguous :: bu(:)           !! B(u^n)
        scale = sqrt(dot(md, md)) + c * sqrt(dot(bu, bu)) + sqrt(b_dot(cb, kb, load, bu))
    end function newton_scale

    !> b . b for b = newton_b(cb, kb, load, bu), each entry formed in the loop: the same
    !> LANES partial sums in the same order as vector_ops' dot(b, b), so the same bits,
    !> without a pass writing b and one reading it.
    pure real(dp) function b_dot(cb, kb, load, bu) result(s)
        real(dp), intent(in) :: cb, kb                      !! coefficients of b
        real(dp), intent(in), contiguous :: load(:)         !! L
        real(dp), intent(in), contiguous :: bu(:)           !! B(u^n)
        real(dp) :: acc(LANES), b
        integer :: i, j, n, nb
        n = size(bu)
        nb = n - mod(n, LANES)
        acc = 0.0_dp
        do i = 1, nb, LANES
            do j = 1, LANES
                b = newton_b(cb, kb, load(i + j - 1), bu(i + j - 1))
                acc(j) = acc(j) + b * b
            end do
        end do
        do i = nb + 1, n
            b = newton_b(cb, kb, load(i), bu(i))
            acc(1) = acc(1) + b * b
        end do
        s = lane_sum(acc)
    end function b_dot

    !> The Newmark-family update from x = u - dx, in one pass: the step's predictor
    !> u~ = u + dt v + c1 a (from the old state), a' = (x - u~) inv, v' = v + g1 a + g2 a',
    !> u' = x, and dvec' = newmark_dvec(u', v', a') for the next step.
    pure subroutine newmark_update(n, dx, inv, g1, g2, dt, c1, k, u, v, a, dvec)
        integer, intent(in) :: n                            !! size
        real(dp), intent(in) :: dx(n)                       !! the step's dx
        real(dp), intent(in) :: inv, g1, g2, dt, c1, k      !! coefficients
        real(dp), intent(inout) :: u(n), v(n), a(n)         !! state
        real(dp), intent(out) :: dvec(n)                    !! u' - u~' + k a'
        real(dp) :: x, ai, vi, uti
        integer :: i
        do i = 1, n
            uti = u(i) + dt * v(i) + c1 * a(i)
            x = u(i) - dx(i)
            ai = (x - uti) * inv
            vi = v(i) + g1 * a(i) + g2 * ai
            u(i) = x
            v(i) = vi
            a(i) = ai
            dvec(i) = newmark_dvec(x, vi, ai, dt, c1, k)
        end do
    end subroutine newmark_update

    !> The theta-scheme update from x = u - dx, in one pass: v' = (x - u - g1 v) inv,
    !> u' = x, and dvec' = theta_dvec(u', v') for the next step.
    pure subroutine theta_update(n, dx, inv, g1, dt, u, v, dvec)
        integer, intent(in) :: n                            !! size
        real(dp), intent(in) :: dx(n)                       !! the step's dx
        real(dp), intent(in) :: inv, g1, dt                 !! coefficients
        real(dp), intent(inout) :: u(n), v(n)               !! state
        real(dp), intent(out) :: dvec(n)                    !! u' - u~'
        real(dp) :: x, vi
        integer :: i
        do i = 1, n
            x = u(i) - dx(i)
            vi = (x - u(i) - g1 * v(i)) * inv
            u(i) = x
            v(i) = vi
            dvec(i) = theta_dvec(x, vi, dt)
        end do
    end subroutine theta_update

    !> Newmark family: u - u~ + k a with the predictor u~ = u + dt v + c1 a of the step
    !> that starts from (u, v, a), c1 = dt^2 (1/2 - beta), k = beta dt^2 am/(1-am).
    elemental real(dp) function newmark_dvec(u, v, a, dt, c1, k) result(d)
        real(dp), intent(in) :: u, v, a                     !! state at one dof
        real(dp), intent(in) :: dt, c1, k                   !! coefficients
        d = u - (u + dt * v + c1 * a) + k * a
    end function newmark_dvec

    !> theta: u - u~ with the predictor u~ = u + dt v.
    elemental real(dp) function theta_dvec(u, v, dt) result(d)
        real(dp), intent(in) :: u, v                        !! state at one dof
        real(dp), intent(in) :: dt                          !! time step
        d = u - (u + dt * v)
    end function theta_dvec

    !> dvec = u - u~ (+ k a), the vector whose product with M enters the next step's
    !> Newton residual, for the state (u, v, a) at the dofs idx (all dofs if absent).
    pure subroutine form_predictor(this, u, v, a, idx)
        class(implicit_scheme_t), intent(inout) :: this     !! scheme (dvec set)
        real(dp), intent(in) :: u(:)                        !! displacement
        real(dp), intent(in) :: v(:)                        !! velocity
        real(dp), intent(in) :: a(:)                        !! acceleration (Newmark family)
        integer, intent(in), optional :: idx(:)             !! dofs
        real(dp) :: c1
        c1 = this%dt**2 * (0.5_dp - this%beta)
        if (present(idx)) then
            if (this%kind == KIND_NEWMARK) then
                this%dvec(idx) = newmark_dvec(u(idx), v(idx), a(idx), this%dt, c1, this%kga)
            else
                this%dvec(idx) = theta_dvec(u(idx), v(idx), this%dt)
            end if
        else
            if (this%kind == KIND_NEWMARK) then
                this%dvec = newmark_dvec(u, v, a, this%dt, c1, this%kga)
            else
                this%dvec = theta_dvec(u, v, this%dt)
            end if
        end if
    end subroutine form_predictor
end module implicit_schemes

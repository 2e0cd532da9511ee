!> The state advanced by time schemes and the abstract scheme interface.
module time_scheme
    use kinds, only: dp, i8
    use model, only: model_t, model_eval_b
    use byte_buffer, only: byte_buffer_t, buf_put, buf_get
    use errors, only: STAT_NUMERIC, STAT_INTERNAL, raise, is_oom_text
    use text, only: real_text
    implicit none
    private

    !> Scheme kinds: a scheme is chosen once, by scheme_kind(name), and known by number.
    integer, parameter, public :: SCHEME_NEWMARK = 1, SCHEME_HHT = 2, SCHEME_HHT_SEED = 3, &
                                  SCHEME_THETA = 4, SCHEME_GALPHA = 5, SCHEME_PC = 6, &
                                  SCHEME_PC_HHT = 7, SCHEME_PC_HHT_SEED = 8, SCHEME_CENTRAL = 9
    !> Causes of a failed step (time_scheme_t%failure), which the run's advice follows: the
    !> step itself (Newton did not converge, a singular contact system, a direct solve),
    !> or conjugate gradients (their limits are &solver keys).
    integer, parameter, public :: FAILURE_NONE = 0, FAILURE_STEP = 1, FAILURE_CG = 2
    !> Their names (&scheme name), in the order of the kinds.
    character(len=*), parameter :: SCHEME_NAMES(9) = [character(len=11) :: 'newmark', 'hht', &
        'hht_seed', 'theta', 'galpha', 'pc', 'pc_hht', 'pc_hht_seed', 'central']

    !> The plain parameters of a scheme (&scheme keys; each scheme reads the ones it needs).
    type, public :: scheme_params_t
        integer :: kind = SCHEME_HHT              !! SCHEME_*
        real(dp) :: dt = 0.0_dp                   !! time step (central: 0 = chosen by the scheme)
        real(dp) :: t_end = 0.0_dp                !! the run's end (a step chosen by the scheme divides it)
        real(dp) :: alpha = 0.0_dp                !! HHT alpha
        real(dp) :: beta = 0.25_dp                !! Newmark / pc beta
        real(dp) :: gamma = 0.5_dp                !! Newmark / pc gamma
        real(dp) :: theta = 0.5_dp                !! theta-scheme theta
        real(dp) :: rho_inf = 1.0_dp              !! galpha spectral radius at infinity
        real(dp) :: newton_tol = 1.0e-10_dp       !! relative residual tolerance
        integer :: newton_maxit = 50              !! Newton iteration limit
        character(len=8) :: solver_kind = 'direct'  !! &solver kind: 'direct', 'cg', 'auto'
        real(dp) :: cg_rtol = 1.0e-12_dp          !! &solver cg_rtol
        integer :: cg_max_iter = 500              !! &solver cg_max_iter
    end type scheme_params_t

    !> State at time t, with B(u) and its parts cached (every scheme needs them).
    type, public :: state_t
        real(dp) :: t = 0.0_dp                  !! time
        real(dp), allocatable :: u(:)           !! displacement (free dofs)
        real(dp), allocatable :: v(:)           !! velocity
        real(dp), allocatable :: a(:)           !! acceleration (schemes that track it)
        real(dp), allocatable :: mv(:)          !! M v, formed from v by a product whenever v
                                                !! changes (never updated incrementally)
        real(dp), allocatable :: bu(:)          !! B(u)
        real(dp), allocatable :: ktu(:)         !! K_theta u
        real(dp), allocatable :: lam(:)         !! augmented Lagrangian multipliers (one a contact
                                                !! node; size 0 for Nitsche and penalty)
        integer :: active = 0                   !! active contact quadrature points at u
        real(dp) :: e_pen = 0.0_dp              !! int [P]_-^2 / (2 gamma) at u
        real(dp) :: e_theta = 0.0_dp            !! sum theta |F| sigma_n^2 / (2 gamma) at u
        real(dp) :: f_n = 0.0_dp                !! total normal contact force at u (<= 0):
                                                !! int [P]_- (Nitsche, penalty), the
                                                !! multipliers' resultant (augmented Lagrangian)
        integer :: newton_its = 0               !! Newton iterations of the last step
        logical :: clear = .false.              !! the last step found P finite and >= 0 at
                                                !! every contact facet's node at u (contact_clear;
                                                !! .false.: not known)
    end type state_t

    !> A time-integration scheme: init (coefficients, factorizations, initial
    !> acceleration), step (t -> t + dt), free (its factors), solver (their backend),
    !> kernel (the triangular solve that runs with them); save and load (what the scheme
    !> carries from one step into the next besides the state: nothing by default).
    type, abstract, public :: time_scheme_t
        real(dp) :: dt = 0.0_dp                 !! time step
        integer :: factorizations = 0           !! sparse numeric factorizations done
        integer :: newton_total = 0             !! Newton iterations over the run
        integer :: failure = FAILURE_NONE       !! cause of the failed step (FAILURE_*)
    contains
        procedure(scheme_init), deferred :: init
        procedure(scheme_step), deferred :: step
        procedure(scheme_free), deferred :: free
        procedure(scheme_solver), deferred :: solver
        procedure(scheme_solver), deferred :: kernel
        procedure :: save => scheme_save_none
        procedure :: load => scheme_load_none
        procedure(scheme_factor_info), deferred :: factor_info
    end type time_scheme_t

    abstract interface
        !> Prepare the scheme for the model; complete the initial state
        !> (st%u, st%v, st%bu, st%ktu given; st%a computed if the scheme needs it).
        subroutine scheme_init(this, mdl, prm, st, stat, errmsg)
            import :: time_scheme_t, model_t, scheme_params_t, state_t
            class(time_scheme_t), intent(inout) :: this         !! scheme
            type(model_t), intent(in) :: mdl                    !! model
            type(scheme_params_t), intent(in) :: prm            !! parameters
            type(state_t), intent(inout) :: st                  !! initial state
            integer, intent(out) :: stat                        !! status
            character(len=*), intent(inout), optional :: errmsg !! message
        end subroutine scheme_init

        !> Advance st by one step dt.
        subroutine scheme_step(this, mdl, st, stat, errmsg)
            import :: time_scheme_t, model_t, state_t
            class(time_scheme_t), intent(inout) :: this         !! scheme
            type(model_t), intent(in) :: mdl                    !! model
            type(state_t), intent(inout) :: st                  !! state (t -> t + dt)
            integer, intent(out) :: stat                        !! status (STAT_NUMERIC: Newton failure)
            character(len=*), intent(inout), optional :: errmsg !! message
        end subroutine scheme_step

        !> Release the scheme's factors.
        subroutine scheme_free(this)
            import :: time_scheme_t
            class(time_scheme_t), intent(inout) :: this         !! scheme
        end subroutine scheme_free

        !> The backend of the scheme's linear systems, or (kernel) the triangular solve
        !> used with its factors ('' before init).
        function scheme_solver(this) result(name)
            import :: time_scheme_t
            class(time_scheme_t), intent(in) :: this            !! scheme
            character(len=:), allocatable :: name
        end function scheme_solver

        !> The fill-reducing ordering and the stored entries of the factor of the
        !> scheme's sparse systems (J0 for the implicit schemes, M for the explicit ones;
        !> '' and 0 without a sparse factor, e.g. a lumped mass).
        subroutine scheme_factor_info(this, ordering, nnz)
            import :: time_scheme_t, i8
            class(time_scheme_t), intent(in) :: this                !! scheme
            character(len=:), allocatable, intent(out) :: ordering  !! ordering's name
            integer(i8), intent(out) :: nnz                         !! stored entries
        end subroutine scheme_factor_info
    end interface

    public :: state_eval, scheme_kind, step_failed, step_solve_failed

contains

    !> A failed step: STAT_NUMERIC with the message 'WHAT at t = T: REASON' (': REASON'
    !> only when the failing routine gave one), t the time the step was to reach; the
    !> cause is kept in this%failure for the run's advice. A REASON that begins 'out of
    !> memory' (errors' oom_text) is STAT_INTERNAL with that line alone: the run's
    !> advice about the step does not apply. A step's failures go through
    !> here, or (Newton did not converge, whose message gives t mid-sentence) set the
    !> cause themselves: each message gives t once, and the run need not read it.
    pure subroutine step_failed(this, cause, what, t, reason, stat, errmsg)
        class(time_scheme_t), intent(inout) :: this         !! scheme
        integer, intent(in) :: cause                        !! FAILURE_STEP or FAILURE_CG
        character(len=*), intent(in) :: what                !! what failed
        real(dp), intent(in) :: t                           !! time the step was to reach
        character(len=*), intent(in) :: reason              !! the failing routine's reason
        integer, intent(out) :: stat                        !! STAT_NUMERIC (STAT_INTERNAL)
        character(len=*), intent(inout), optional :: errmsg !! message
        this%failure = cause
        if (is_oom_text(reason)) then
            ! not a numerical failure: the line is the allocation's (stage, bytes, hint)
            call raise(stat, errmsg, STAT_INTERNAL, trim(reason))
        else if (len_trim(reason) > 0) then
            call raise(stat, errmsg, STAT_NUMERIC, what//' at t = '//real_text(t, 6)//': '// &
                       trim(reason))
        else
            call raise(stat, errmsg, STAT_NUMERIC, what//' at t = '//real_text(t, 6))
        end if
    end subroutine step_failed

    !> A failed linear solve in a step: step_failed with the solver's reason, which it
    !> left in errmsg; the cause is FAILURE_CG when the solve was by conjugate gradients.
    pure subroutine step_solve_failed(this, cg, what, t, stat, errmsg)
        class(time_scheme_t), intent(inout) :: this         !! scheme
        logical, intent(in) :: cg                           !! the solve was by CG
        character(len=*), intent(in) :: what                !! what failed
        real(dp), intent(in) :: t                           !! time the step was to reach
        integer, intent(out) :: stat                        !! STAT_NUMERIC
        character(len=*), intent(inout), optional :: errmsg !! the solver's reason in, ours out
        character(len=:), allocatable :: why
        why = ''
        if (present(errmsg)) why = trim(errmsg)
        if (cg) then
            call step_failed(this, FAILURE_CG, what, t, why, stat, errmsg)
        else
            call step_failed(this, FAILURE_STEP, what, t, why, stat, errmsg)
        end if
    end subroutine step_solve_failed

    !> The time step only: the explicit schemes carry nothing between steps besides
    !> the state.
    pure subroutine scheme_save_none(this, buf)
        class(time_scheme_t), intent(in) :: this            !! scheme
        type(byte_buffer_t), intent(inout) :: buf           !! checkpoint payload
        call buf_put(buf, this%dt)
    end subroutine scheme_save_none

    !> Read back scheme_save_none's time step: bad unless it is this scheme's, bit for bit.
    pure subroutine scheme_load_none(this, buf)
        class(time_scheme_t), intent(inout) :: this         !! scheme (set up by init)
        type(byte_buffer_t), intent(inout) :: buf           !! checkpoint payload
        real(dp) :: dt
        call buf_get(buf, dt)
        if (.not. dt == this%dt) buf%bad = .true.
    end subroutine scheme_load_none

    !> The kind of the scheme called `name` (&scheme name); 0 if there is none.
    pure function scheme_kind(name) result(kind)
        character(len=*), intent(in) :: name   !! scheme name
        integer :: kind
        do kind = 1, size(SCHEME_NAMES)
            if (trim(name) == trim(SCHEME_NAMES(kind))) return
        end do
        kind = 0
    end function scheme_kind

    !> Recompute the cached B(u) parts of a state from st%u.
    pure subroutine state_eval(mdl, st)
        type(model_t), intent(in) :: mdl       !! model
        type(state_t), intent(inout) :: st     !! state
        call model_eval_b(mdl, st%u, st%bu, st%ktu, st%active, st%e_pen, st%e_theta, st%f_n)
    end subroutine state_eval
end module time_scheme

!> The state advanced by time schemes and the abstract scheme interface.
module time_scheme
    use kinds, only: dp
    use model, only: model_t, model_eval_b
    use scene, only: scene_t
    implicit none
    private

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
        integer :: active = 0                   !! active contact quadrature points at u
        real(dp) :: e_pen = 0.0_dp              !! int [P]_-^2 / (2 gamma) at u
        real(dp) :: e_theta = 0.0_dp            !! sum theta |F| sigma_n^2 / (2 gamma) at u
        integer :: newton_its = 0               !! Newton iterations of the last step
    end type state_t

    !> A time-integration scheme: init (coefficients, factorizations, initial
    !> acceleration) then step (t -> t + dt).
    type, abstract, public :: time_scheme_t
        real(dp) :: dt = 0.0_dp                 !! time step
        integer :: factorizations = 0           !! sparse numeric factorizations done
        integer :: newton_total = 0             !! Newton iterations over the run
    contains
        procedure(scheme_init), deferred :: init
        procedure(scheme_step), deferred :: step
    end type time_scheme_t

    abstract interface
        !> Prepare the scheme for the model and scene; complete the initial state
        !> (st%u, st%v, st%bu, st%ktu given; st%a computed if the scheme needs it).
        subroutine scheme_init(this, mdl, scn, st, stat, errmsg)
            import :: time_scheme_t, model_t, scene_t, state_t
            class(time_scheme_t), intent(inout) :: this         !! scheme
            type(model_t), intent(in) :: mdl                    !! model
            type(scene_t), intent(in) :: scn                    !! scene
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
    end interface

    public :: state_eval

contains

    !> Recompute the cached B(u) parts of a state from st%u.
    subroutine state_eval(mdl, st)
        type(model_t), intent(in) :: mdl       !! model
        type(state_t), intent(inout) :: st     !! state
        call model_eval_b(mdl, st%u, st%bu, st%ktu, st%active, st%e_pen, st%e_theta)
    end subroutine state_eval
end module time_scheme

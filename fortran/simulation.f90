!> A run of one scene: model, time scheme, state and outputs, advanced in chunks.
module simulation
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_INTERNAL, raise
    implicit none
    private

    !> One simulation (owned by the caller; no module state).
    type, public :: simulation_t
        integer :: n_dofs = 0          !! free dofs
        integer :: n_cells = 0         !! elements
        integer :: n_contact = 0       !! contact facets
        integer :: n_steps = 0         !! steps to reach t_end
        integer :: step = 0            !! steps done
        logical :: finished = .false.  !! t_end reached or stopped
    end type simulation_t

    public :: sim_open, sim_advance, sim_close, sim_eval_b, sim_apply_jacobian, sim_static, &
              sim_dof_map

contains

    !> Read the scene, build the model, open the outputs (nothing is overwritten
    !> before this succeeds) and write the t = 0 row. `out_dir` /= '' overrides &output dir.
    subroutine sim_open(sim, scene_path, out_dir, write_output, stat, errmsg)
        type(simulation_t), intent(out) :: sim              !! the run
        character(len=*), intent(in) :: scene_path          !! scene file
        character(len=*), intent(in) :: out_dir             !! output folder override ('' = scene's)
        logical, intent(in) :: write_output                 !! .false.: build the model only
        integer, intent(out) :: stat                        !! STAT_OK, STAT_BAD_INPUT, ...
        character(len=*), intent(inout), optional :: errmsg !! message
        sim%n_dofs = 0
        call raise(stat, errmsg, STAT_INTERNAL, trim(scene_path)//trim(out_dir)//': not implemented')
        if (write_output) return
    end subroutine sim_open

    !> Advance at most max_steps steps. A blow-up or Newton failure stops the run
    !> (finished = .true.) with STAT_NUMERIC; the trace so far is kept.
    subroutine sim_advance(sim, max_steps, steps_done, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run
        integer, intent(in) :: max_steps                    !! step budget of this call
        integer, intent(out) :: steps_done                  !! steps done in this call
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        steps_done = 0
        sim%step = sim%step + max_steps * 0
        stat = STAT_OK
        if (present(errmsg)) errmsg = ''
    end subroutine sim_advance

    !> Write summary.json (when outputs are open) and release everything.
    subroutine sim_close(sim, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        sim = simulation_t()
        stat = STAT_OK
        if (present(errmsg)) errmsg = ''
    end subroutine sim_close

    !> b = B(u) on the free dofs; active = active contact quadrature points.
    subroutine sim_eval_b(sim, u, b, active)
        type(simulation_t), intent(inout) :: sim   !! the run (model used)
        real(dp), intent(in) :: u(:)               !! displacement (free dofs)
        real(dp), intent(out) :: b(:)              !! B(u)
        integer, intent(out) :: active             !! active quadrature points
        b = u * sim%n_dofs
        active = 0
    end subroutine sim_eval_b

    !> jdu = B'(u) du, the generalized (semi-smooth Newton) derivative.
    subroutine sim_apply_jacobian(sim, u, du, jdu)
        type(simulation_t), intent(inout) :: sim   !! the run
        real(dp), intent(in) :: u(:)               !! point of linearization
        real(dp), intent(in) :: du(:)              !! direction
        real(dp), intent(out) :: jdu(:)            !! B'(u) du
        jdu = u * du * sim%n_dofs
    end subroutine sim_apply_jacobian

    !> Static solve K u = L (no contact, no inertia) on the free dofs.
    subroutine sim_static(sim, u, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run
        real(dp), intent(out) :: u(:)                       !! displacement (free dofs)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        u = sim%n_dofs
        call raise(stat, errmsg, STAT_INTERNAL, 'not implemented')
    end subroutine sim_static

    !> Node (1-based) and component (1..dim) of each free dof.
    subroutine sim_dof_map(sim, node, comp)
        type(simulation_t), intent(in) :: sim   !! the run
        integer, intent(out) :: node(:)         !! (n_dofs) node of each free dof
        integer, intent(out) :: comp(:)         !! (n_dofs) component of each free dof
        node = sim%n_dofs
        comp = 0
    end subroutine sim_dof_map
end module simulation

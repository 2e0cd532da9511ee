!> Helpers of the flat API (api.f90): handle <-> simulation or mesh pointer, and the hooks the
!> tests and the benchmark use on an open run (B(u), B'(u) du, the static solution,
!> the dof map, the cost floors of a step). The run itself is in module simulation.
module api_handles
    use iso_c_binding, only: c_int64_t, c_ptr, c_f_pointer, c_loc
    use kinds, only: dp, i8
    use errors, only: STAT_OK
    use model, only: model_eval_b, model_apply_jacobian, model_stiff_apply
    use implicit_schemes, only: implicit_scheme_t
    use explicit_schemes, only: pc_scheme_t
    use central_difference, only: central_scheme_t
    use mass_solver, only: mass_solver_t, mass_solver_apply
    use linear_solver, only: factor_t, ls_factor, ls_solve, ls_free, BACKEND_CHOLMOD
    use cholmod, only: cholmod_t, chol_factor, chol_solve_cholmod, chol_free
    use simulation, only: simulation_t, sim_open
    use mesh, only: mesh_t
    implicit none
    private
    public :: sim_from_handle, sim_open_handle, mesh_from_handle, sim_bench_floor, sim_eval_b, &
              sim_apply_jacobian, sim_static, sim_dof_map

contains

    !> The simulation behind an opaque handle made by dc_sim_open.
    subroutine sim_from_handle(handle, sim)
        integer(c_int64_t), intent(in) :: handle          !! handle
        type(simulation_t), pointer, intent(out) :: sim   !! the run
        type(c_ptr) :: p
        p = transfer(handle, p)
        call c_f_pointer(p, sim)
    end subroutine sim_from_handle

    !> Open a run on the heap (sim_open with these arguments) behind an opaque handle
    !> for sim_from_handle; on failure the run is freed and the handle is 0.
    subroutine sim_open_handle(path, out_dir, write_output, handle, sim, stat, errmsg, restart, &
                               out_said)
        character(len=*), intent(in) :: path                !! scene file
        character(len=*), intent(in) :: out_dir             !! output folder override ('' = scene's)
        logical, intent(in) :: write_output                 !! .false.: build the model only
        integer(c_int64_t), intent(out) :: handle           !! the run's handle (0 on error)
        type(simulation_t), pointer, intent(out) :: sim     !! the run (null on error)
        integer, intent(out) :: stat                        !! sim_open's status
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=*), intent(in), optional :: restart   !! checkpoint folder (sim_open)
        character(len=*), intent(in), optional :: out_said  !! the output folder in messages (sim_open)
        handle = 0
        allocate (sim)
        call sim_open(sim, path, out_dir, write_output, stat, errmsg, restart=restart, &
                      out_said=out_said)
        if (stat /= STAT_OK) then
            deallocate (sim)
            return
        end if
        handle = transfer(c_loc(sim), handle)
    end subroutine sim_open_handle

    !> The mesh behind an opaque handle made by dc_mesh_sizes.
    subroutine mesh_from_handle(handle, msh)
        integer(c_int64_t), intent(in) :: handle          !! handle (not 0)
        type(mesh_t), pointer, intent(out) :: msh         !! the mesh
        type(c_ptr) :: p
        p = transfer(handle, p)
        call c_f_pointer(p, msh)
    end subroutine mesh_from_handle

    !> Cost floors of a run's step, in microseconds (mean over n_rep repetitions):
    !> one triangular solve with the cached factors of the iteration matrix (implicit
    !> schemes; 0 otherwise), one SpMV with K_theta, one M^{-1} application (pc
    !> schemes; 0 otherwise), and the iteration matrix's solve through cholmod_solve2 on
    !> the same factor (0 when its factors are not CHOLMOD's), to compare with the solve
    !> the run uses.
    subroutine sim_bench_floor(sim, n_rep, t_solve, t_spmv, t_mass, t_cholmod)
        type(simulation_t), intent(inout) :: sim   !! an open run
        integer, intent(in) :: n_rep               !! repetitions (> 0)
        real(dp), intent(out) :: t_solve           !! us per triangular solve
        real(dp), intent(out) :: t_spmv            !! us per SpMV with K_theta
        real(dp), intent(out) :: t_mass            !! us per M^{-1} application
        real(dp), intent(out) :: t_cholmod         !! us per cholmod_solve2 of the same system
        real(dp), allocatable :: b(:), x(:)
        integer(i8) :: c0, c1
        integer :: i, st
        allocate (b(sim%n_dofs), x(sim%n_dofs))
        call random_number(b)
        t_solve = 0.0_dp; t_mass = 0.0_dp; t_cholmod = 0.0_dp
        call system_clock(c0)
        do i = 1, n_rep
            call model_stiff_apply(sim%mdl, b, x)
        end do
        call system_clock(c1)
        t_spmv = us_per_rep()
        if (.not. allocated(sim%scheme)) return
        select type (s => sim%scheme)
        type is (implicit_scheme_t)
            call system_clock(c0)
            do i = 1, n_rep
                call ls_solve(s%lu0, sim%mdl%stiff, b, x, st, val=s%jac0)
            end do
            call system_clock(c1)
            t_solve = us_per_rep()
            ! cholmod_solve2 on the same factor: CHOLMOD's copy is released when the run
            ! solves on the block copy, so the floor factorizes J0 once more, keeping it
            ! (the same analysis and ordering: the same factor)
            if (s%lu0%backend == BACKEND_CHOLMOD) then
                block
                    type(cholmod_t) :: ch
                    ch%keep_cholmod = .true.
                    call chol_factor(ch, sim%mdl%stiff, st, val=s%jac0)
                    if (st == STAT_OK) then
                        call system_clock(c0)
                        do i = 1, n_rep
                            call chol_solve_cholmod(ch, b, x, st)
                        end do
                        call system_clock(c1)
                        t_cholmod = us_per_rep()
                    end if
                    call chol_free(ch)
                end block
            end if
        type is (pc_scheme_t)
            t_mass = mass_apply_us(s%ms)
        type is (central_scheme_t)
            t_mass = mass_apply_us(s%ms)
        end select

    contains

        !> us per M^{-1} application with the scheme's mass solver.
        function mass_apply_us(ms) result(t)
            type(mass_solver_t), intent(inout) :: ms   !! the scheme's mass solver
            real(dp) :: t
            call system_clock(c0)
            do i = 1, n_rep
                call mass_solver_apply(ms, b, x, st)
            end do
            call system_clock(c1)
            t = us_per_rep()
        end function mass_apply_us

        !> us per repetition between the clock readings c0 and c1.
        pure real(dp) function us_per_rep()
            us_per_rep = 1.0e6_dp * real(c1 - c0, dp) / sim%clock_rate / n_rep
        end function us_per_rep
    end subroutine sim_bench_floor

    !> b = B(u) on the free dofs; active = active contact quadrature points.
    pure subroutine sim_eval_b(sim, u, b, active)
        type(simulation_t), intent(in) :: sim      !! the run (model used)
        real(dp), intent(in) :: u(:)               !! displacement (free dofs)
        real(dp), intent(out) :: b(:)              !! B(u)
        integer, intent(out) :: active             !! active quadrature points
        real(dp) :: e1, e2
        real(dp), allocatable :: ktu(:)
        allocate (ktu(size(u)))
        call model_eval_b(sim%mdl, u, b, ktu, active, e1, e2)
    end subroutine sim_eval_b

    !> jdu = B'(u) du, the generalized (semi-smooth Newton) derivative.
    pure subroutine sim_apply_jacobian(sim, u, du, jdu)
        type(simulation_t), intent(inout) :: sim   !! the run
        real(dp), intent(in) :: u(:)               !! point of linearization
        real(dp), intent(in) :: du(:)              !! direction
        real(dp), intent(out) :: jdu(:)            !! B'(u) du
        call model_apply_jacobian(sim%mdl, u, du, jdu)
    end subroutine sim_apply_jacobian

    !> Static solve K u = L (no contact, no inertia) on the free dofs.
    subroutine sim_static(sim, u, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run
        real(dp), intent(out) :: u(:)                       !! displacement (free dofs)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        type(factor_t) :: lu
        call ls_factor(lu, sim%mdl%stiff, stat, errmsg)
        if (stat == STAT_OK) call ls_solve(lu, sim%mdl%stiff, sim%mdl%load, u, stat, errmsg)
        call ls_free(lu)
    end subroutine sim_static

    !> Node (1-based) and component (1..dim) of each free dof.
    pure subroutine sim_dof_map(sim, node, comp)
        type(simulation_t), intent(in) :: sim   !! the run
        integer, intent(out) :: node(:)         !! (n_dofs) node of each free dof
        integer, intent(out) :: comp(:)         !! (n_dofs) component of each free dof
        node = sim%mdl%dof_node
        comp = sim%mdl%dof_comp
    end subroutine sim_dof_map
end module api_handles

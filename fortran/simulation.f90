!> A run of one scene: model, time scheme, state and outputs, advanced in chunks
!> (the executable loops over sim_advance; Python calls it through the flat API
!> and shows progress between chunks).
module simulation
    use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
    use kinds, only: dp, i8
    use errors, only: STAT_OK, STAT_NUMERIC, STAT_INTERNAL, raise
    use scene, only: scene_t, scene_read, scene_to_json
    use model, only: model_t, model_build, model_eval_b, model_apply_jacobian, model_initial, &
                     model_probe, model_mass_apply, model_stiff_apply, model_full_field
    use time_scheme, only: time_scheme_t, state_t, state_eval
    use implicit_schemes, only: implicit_scheme_t
    use explicit_schemes, only: pc_scheme_t
    use central_difference, only: central_scheme_t
    use mass_solver, only: mass_solver_apply
    use linear_solver, only: factor_t, ls_factor, ls_solve, ls_free
    use trace_output, only: make_dirs, trace_open, trace_row, json_real, json_string
    use vtk_output, only: vtk_write_vtu, vtk_write_pvd
    use version_info, only: DYNCONTACT_VERSION
    implicit none
    private

    !> One simulation (owned by the caller; no module state).
    type, public :: simulation_t
        integer :: n_dofs = 0                      !! free dofs
        integer :: n_cells = 0                     !! elements
        integer :: n_contact = 0                   !! contact facets
        integer :: n_steps = 0                     !! steps to reach t_end
        integer :: step = 0                        !! steps done
        logical :: finished = .false.              !! t_end reached or stopped
        character(len=32) :: status = 'ok'         !! ok | unstable | newton_failed | interrupted
        character(len=512) :: message = ''         !! why the run stopped early
        type(scene_t) :: scn                       !! the scene
        type(model_t) :: mdl                       !! the model
        class(time_scheme_t), allocatable :: scheme !! the time scheme
        type(state_t) :: st                        !! current state
        logical :: outputs = .false.               !! outputs open
        integer :: trace_unit = -1                 !! trace.csv unit
        real(dp) :: e0 = 0.0_dp                    !! e_total(0)
        integer(i8) :: clock0 = 0                  !! wall clock at open
        integer(i8) :: clock_rate = 1              !! ticks per second
        real(dp), allocatable :: work(:)           !! scratch (n_dofs)
        integer :: n_snap = 0                      !! field snapshots written
        real(dp), allocatable :: snap_t(:)         !! their times
        character(len=64), allocatable :: snap_file(:) !! their file names
    end type simulation_t

    public :: sim_bench_floor
    public :: sim_open, sim_open_scene, sim_advance, sim_close, sim_eval_b, sim_apply_jacobian, sim_static, &
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
        type(scene_t) :: scn
        call scene_read(scene_path, scn, stat, errmsg)
        if (stat /= STAT_OK) return
        if (len_trim(out_dir) > 0) scn%out_dir = out_dir
        call sim_open_scene(sim, scn, write_output, stat, errmsg)
    end subroutine sim_open

    !> sim_open for a scene already read and validated.
    subroutine sim_open_scene(sim, scn, write_output, stat, errmsg)
        type(simulation_t), intent(out) :: sim              !! the run
        type(scene_t), intent(in) :: scn                    !! validated scene
        logical, intent(in) :: write_output                 !! .false.: build the model only
        integer, intent(out) :: stat                        !! STAT_OK, STAT_BAD_INPUT, ...
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: n
        call system_clock(sim%clock0, sim%clock_rate)
        sim%scn = scn
        call model_build(sim%scn, sim%mdl, stat, errmsg)
        if (stat /= STAT_OK) return
        n = sim%mdl%n_dofs
        sim%n_dofs = n
        sim%n_cells = sim%mdl%msh%n_cells
        sim%n_contact = sim%mdl%ct%n_facets
        sim%n_steps = max(0, ceiling(sim%scn%t_end / sim%scn%dt - 1.0e-9_dp))
        allocate (sim%st%u(n), sim%st%v(n), sim%st%a(n), sim%st%bu(n), sim%st%ktu(n), &
                  sim%st%mv(n), sim%work(n))
        call model_initial(sim%mdl, sim%scn, sim%st%u, sim%st%v)
        call state_eval(sim%mdl, sim%st)
        call model_mass_apply(sim%mdl, sim%st%v, sim%st%mv)
        sim%st%a = 0.0_dp
        if (.not. write_output) return
        select case (trim(sim%scn%scheme_name))
        case ('pc', 'pc_hht', 'pc_hht_seed')
            allocate (pc_scheme_t :: sim%scheme)
        case ('central')
            allocate (central_scheme_t :: sim%scheme)
        case default
            allocate (implicit_scheme_t :: sim%scheme)
        end select
        call sim%scheme%init(sim%mdl, sim%scn, sim%st, stat, errmsg)
        if (stat /= STAT_OK) return
        ! a scheme may choose its step (central with dt = 0): the run uses the scheme's
        if (sim%scheme%dt /= sim%scn%dt) then
            sim%scn%dt = sim%scheme%dt
            sim%n_steps = max(0, ceiling(sim%scn%t_end / sim%scn%dt - 1.0e-9_dp))
        end if

        call make_dirs(sim%scn%out_dir, stat, errmsg)
        if (stat /= STAT_OK) return
        call trace_open(trim(sim%scn%out_dir)//'/trace.csv', sim%trace_unit, stat, errmsg)
        if (stat /= STAT_OK) return
        sim%outputs = .true.
        sim%status = 'running'
        call write_summary(sim, stat, errmsg)
        if (stat /= STAT_OK) return
        sim%status = 'ok'
        if (sim%scn%fields_every > 0) then
            call make_dirs(trim(sim%scn%out_dir)//'/fields', stat, errmsg)
            if (stat /= STAT_OK) return
            allocate (sim%snap_t(sim%n_steps / sim%scn%fields_every + 2), &
                      sim%snap_file(sim%n_steps / sim%scn%fields_every + 2))
            call snapshot(sim, stat, errmsg)
            if (stat /= STAT_OK) return
        end if
        call record(sim, sim%e0)
        sim%finished = sim%n_steps == 0
    end subroutine sim_open_scene

    !> Advance at most max_steps steps. A blow-up or Newton failure stops the run
    !> (finished = .true.) with STAT_NUMERIC; the trace so far is kept.
    subroutine sim_advance(sim, max_steps, steps_done, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run
        integer, intent(in) :: max_steps                    !! step budget of this call
        integer, intent(out) :: steps_done                  !! steps done in this call
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp) :: e_total
        logical :: row
        character(len=256) :: msg
        stat = STAT_OK
        steps_done = 0
        if (.not. sim%outputs) then
            call raise(stat, errmsg, STAT_INTERNAL, 'sim_advance: the run has no outputs open')
            return
        end if
        do while (.not. sim%finished .and. steps_done < max_steps)
            call sim%scheme%step(sim%mdl, sim%st, stat, msg)
            if (stat /= STAT_OK) then
                sim%status = 'newton_failed'
                sim%message = msg
                sim%finished = .true.
                call raise(stat, errmsg, STAT_NUMERIC, trim(msg))
                return
            end if
            sim%step = sim%step + 1
            steps_done = steps_done + 1
            sim%st%t = sim%step * sim%scn%dt
            row = mod(sim%step, sim%scn%every) == 0 .or. sim%step == sim%n_steps
            call record(sim, e_total, row)
            if (.not. ieee_is_finite(e_total) .or. &
                e_total > sim%scn%blowup * max(sim%e0, tiny(1.0_dp))) then
                if (.not. row) call record(sim, e_total)
                sim%status = 'unstable'
                write (msg, '(a, es12.5, a, es10.3, a, es10.3, a)') 'unstable at t = ', sim%st%t, &
                    ': e_total = ', e_total, ' exceeds blowup x e_total(0) = ', &
                    sim%scn%blowup * max(sim%e0, tiny(1.0_dp)), ' (run stopped, trace kept)'
                sim%message = msg
                sim%finished = .true.
                call raise(stat, errmsg, STAT_NUMERIC, trim(msg))
                return
            end if
            if (sim%scn%fields_every > 0) then
                if (mod(sim%step, sim%scn%fields_every) == 0) then
                    call snapshot(sim, stat, errmsg)
                    if (stat /= STAT_OK) return
                end if
            end if
            if (sim%step >= sim%n_steps) sim%finished = .true.
        end do
    end subroutine sim_advance

    !> Write summary.json (when outputs are open) and release everything.
    subroutine sim_close(sim, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        stat = STAT_OK
        if (sim%outputs) then
            if (.not. sim%finished) sim%status = 'interrupted'
            close (sim%trace_unit)
            call write_summary(sim, stat, errmsg)
            if (stat == STAT_OK .and. sim%n_snap > 0) &
                call vtk_write_pvd(trim(sim%scn%out_dir)//'/fields.pvd', sim%snap_t(1:sim%n_snap), &
                                   sim%snap_file(1:sim%n_snap), stat, errmsg)
            sim%outputs = .false.
        end if
        if (allocated(sim%scheme)) then
            select type (s => sim%scheme)
            type is (implicit_scheme_t)
                call ls_free(s%lu0)
            type is (pc_scheme_t)
                call ls_free(s%ms%lu)
            type is (central_scheme_t)
                call ls_free(s%ms%lu)
            end select
        end if
    end subroutine sim_close

    !> Energies and probe values of the current state; a trace row when `row`
    !> is absent or true. e_total = e_kin + e_el is returned.
    subroutine record(sim, e_total, row)
        type(simulation_t), intent(inout) :: sim   !! the run
        real(dp), intent(out) :: e_total           !! e_kin + e_el
        logical, intent(in), optional :: row       !! write the row (default yes)
        real(dp) :: e_kin, e_el, e_contact, un, vn, pn
        e_kin = 0.5_dp * dot_product(sim%st%v, sim%st%mv)
        e_el = 0.5_dp * dot_product(sim%st%u, sim%st%ktu) + sim%st%e_theta
        e_contact = sim%st%e_pen - sim%st%e_theta
        e_total = e_kin + e_el
        if (present(row)) then
            if (.not. row) return
        end if
        call model_probe(sim%mdl, sim%st%u, sim%st%v, un, vn, pn)
        call trace_row(sim%trace_unit, sim%st%t, un, vn, pn, e_kin, e_el, e_contact, e_total, &
                       sim%st%newton_its, sim%st%active)
    end subroutine record

    !> Write a VTU snapshot of the current displacement and velocity.
    subroutine snapshot(sim, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), allocatable :: uf(:, :), vf(:, :)
        character(len=64) :: name
        allocate (uf(sim%mdl%dim, sim%mdl%msh%n_nodes), vf(sim%mdl%dim, sim%mdl%msh%n_nodes))
        call model_full_field(sim%mdl, sim%st%u, uf)
        call model_full_field(sim%mdl, sim%st%v, vf)
        write (name, '(a, i7.7, a)') 'fields/step_', sim%step, '.vtu'
        call vtk_write_vtu(trim(sim%scn%out_dir)//'/'//trim(name), sim%mdl%dim, sim%mdl%msh%x, &
                           sim%mdl%msh%cells, uf, vf, stat, errmsg)
        if (stat /= STAT_OK) return
        sim%n_snap = sim%n_snap + 1
        sim%snap_t(sim%n_snap) = sim%st%t
        sim%snap_file(sim%n_snap) = name
    end subroutine snapshot

    !> summary.json (SPEC section 4).
    subroutine write_summary(sim, stat, errmsg)
        type(simulation_t), intent(in) :: sim               !! the run
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: unit, ios, its, facts
        integer(i8) :: clock
        character(len=:), allocatable :: path
        character(len=32) :: buf
        stat = STAT_OK
        path = trim(sim%scn%out_dir)//'/summary.json'
        open (newunit=unit, file=path, status='replace', action='write', iostat=ios)
        if (ios /= 0) then
            call raise(stat, errmsg, STAT_INTERNAL, path//': cannot write')
            return
        end if
        call system_clock(clock)
        its = 0; facts = 0
        if (allocated(sim%scheme)) then
            its = sim%scheme%newton_total
            facts = sim%scheme%factorizations
        end if
        write (unit, '(a)') '{'
        write (unit, '(a)') '  "status": '//json_string(sim%status)//','
        write (unit, '(a)') '  "message": '//json_string(sim%message)//','
        write (buf, '(i0)') sim%step
        write (unit, '(a)') '  "steps": '//trim(buf)//','
        write (unit, '(a)') '  "t_end_reached": '//json_real(sim%st%t)//','
        write (unit, '(a)') '  "wall_s": '//json_real(real(clock - sim%clock0, dp) / sim%clock_rate)//','
        write (buf, '(i0)') its
        write (unit, '(a)') '  "newton_its_total": '//trim(buf)//','
        write (buf, '(i0)') facts
        write (unit, '(a)') '  "factorizations": '//trim(buf)//','
        write (buf, '(i0)') sim%n_dofs
        write (unit, '(a)') '  "dofs": '//trim(buf)//','
        write (buf, '(i0)') sim%n_cells
        write (unit, '(a)') '  "elements": '//trim(buf)//','
        write (buf, '(i0)') sim%n_contact
        write (unit, '(a)') '  "contact_facets": '//trim(buf)//','
        write (unit, '(a)') '  "scheme": '//json_string(sim%scn%scheme_name)//','
        if (allocated(sim%scheme)) then
            select type (s => sim%scheme)
            type is (central_scheme_t)
                write (unit, '(a)') '  "dt_crit_estimate": '//json_real(s%dt_crit)//','
            end select
        end if
        write (unit, '(a)') '  "solver": '//json_string(sim_solver(sim))//','
        write (unit, '(a)') '  "scene": '//scene_to_json(sim%scn)//','
        write (unit, '(a)') '  "version": '//json_string(DYNCONTACT_VERSION)
        write (unit, '(a)') '}'
        close (unit)
    end subroutine write_summary

    !> The solver of the run's linear systems: the backend of the J0 factors (implicit
    !> schemes) or of the M factors (pc schemes; 'diagonal' for lumped mass); '' before
    !> the scheme is set up.
    function sim_solver(sim) result(name)
        type(simulation_t), intent(in) :: sim   !! the run
        character(len=:), allocatable :: name
        name = ''
        if (.not. allocated(sim%scheme)) return
        select type (s => sim%scheme)
        type is (implicit_scheme_t)
            name = trim(s%lu0%backend)
        type is (pc_scheme_t)
            name = trim(s%ms%lu%backend)
            if (s%ms%lumped) name = 'diagonal'
        type is (central_scheme_t)
            name = trim(s%ms%lu%backend)
            if (s%ms%lumped) name = 'diagonal'
        end select
    end function sim_solver

    !> Cost floors of a run's step, in microseconds (mean over n_rep repetitions):
    !> one solve with the cached factors of the iteration matrix by the backend the run
    !> uses (CHOLMOD LDL^T or UMFPACK LU, see sim_solver; implicit schemes; 0 otherwise),
    !> one SpMV with K_theta, one M^{-1} application (pc schemes; 0 otherwise).
    subroutine sim_bench_floor(sim, n_rep, t_solve, t_spmv, t_mass)
        type(simulation_t), intent(inout) :: sim   !! an open run
        integer, intent(in) :: n_rep               !! repetitions (> 0)
        real(dp), intent(out) :: t_solve           !! us per triangular solve
        real(dp), intent(out) :: t_spmv            !! us per SpMV with K_theta
        real(dp), intent(out) :: t_mass            !! us per M^{-1} application
        real(dp), allocatable :: b(:), x(:)
        integer(i8) :: c0, c1
        integer :: i, st
        allocate (b(sim%n_dofs), x(sim%n_dofs))
        call random_number(b)
        t_solve = 0.0_dp; t_mass = 0.0_dp
        call system_clock(c0)
        do i = 1, n_rep
            call model_stiff_apply(sim%mdl, b, x)
        end do
        call system_clock(c1)
        t_spmv = 1.0e6_dp * real(c1 - c0, dp) / sim%clock_rate / n_rep
        if (.not. allocated(sim%scheme)) return
        select type (s => sim%scheme)
        type is (implicit_scheme_t)
            call system_clock(c0)
            do i = 1, n_rep
                call ls_solve(s%lu0, s%jac0, b, x, st)
            end do
            call system_clock(c1)
            t_solve = 1.0e6_dp * real(c1 - c0, dp) / sim%clock_rate / n_rep
        type is (pc_scheme_t)
            call system_clock(c0)
            do i = 1, n_rep
                call mass_solver_apply(s%ms, b, x, st)
            end do
            call system_clock(c1)
            t_mass = 1.0e6_dp * real(c1 - c0, dp) / sim%clock_rate / n_rep
        type is (central_scheme_t)
            call system_clock(c0)
            do i = 1, n_rep
                call mass_solver_apply(s%ms, b, x, st)
            end do
            call system_clock(c1)
            t_mass = 1.0e6_dp * real(c1 - c0, dp) / sim%clock_rate / n_rep
        end select
    end subroutine sim_bench_floor

    !> b = B(u) on the free dofs; active = active contact quadrature points.
    subroutine sim_eval_b(sim, u, b, active)
        type(simulation_t), intent(inout) :: sim   !! the run (model used)
        real(dp), intent(in) :: u(:)               !! displacement (free dofs)
        real(dp), intent(out) :: b(:)              !! B(u)
        integer, intent(out) :: active             !! active quadrature points
        real(dp) :: e1, e2
        call model_eval_b(sim%mdl, u, b, sim%work, active, e1, e2)
    end subroutine sim_eval_b

    !> jdu = B'(u) du, the generalized (semi-smooth Newton) derivative.
    subroutine sim_apply_jacobian(sim, u, du, jdu)
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
    subroutine sim_dof_map(sim, node, comp)
        type(simulation_t), intent(in) :: sim   !! the run
        integer, intent(out) :: node(:)         !! (n_dofs) node of each free dof
        integer, intent(out) :: comp(:)         !! (n_dofs) component of each free dof
        node = sim%mdl%dof_node
        comp = sim%mdl%dof_comp
    end subroutine sim_dof_map
end module simulation

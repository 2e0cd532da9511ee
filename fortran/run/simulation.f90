!> A run of one scene: model, time scheme, state and outputs, advanced in chunks
!> (the executable loops over sim_advance; Python calls it through the flat API
!> and shows progress between chunks).
module simulation
    use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
    use kinds, only: dp, i8
    use text, only: int_text, real_text, fixed_text, lower
    use vector_ops, only: dot
    use errors, only: STAT_OK, STAT_BAD_INPUT, STAT_NUMERIC, STAT_INTERNAL, STAT_INTERRUPTED, raise, &
                      has_room, oom_text, is_oom_text, mb_text, OOM_HINT_MESH
    use scene, only: scene_t, scene_read, scene_to_json, scene_check_dim, scene_bar_dim, &
                     scene_given, scene_json_diff
    use mesh, only: mesh_t
    use mesh_source, only: mesh_load, mesh_label
    use gmsh_mesh, only: file_extension, geo_given
    use nitsche_contact, only: QUAD_EXACT, QUAD_GAUSS
    use alm_contact, only: ALM_OFF, ALM_INTEGRAL, ALM_NODAL
    use model, only: model_t, model_params_t, model_build, model_initial, model_lift_length, &
                     model_check_initial, &
                     model_probe, model_mass_apply, model_full_field, MASS_CONSISTENT, &
                     MASS_LUMPED, MASS_REDISTRIBUTED, INITIAL_REST, INITIAL_VELOCITY, &
                     INITIAL_COMPRESSED_BAR
    use time_scheme, only: time_scheme_t, state_t, state_eval, scheme_params_t, scheme_kind, &
                           SCHEME_PC, SCHEME_PC_HHT, SCHEME_PC_HHT_SEED, SCHEME_CENTRAL, &
                           FAILURE_CG
    use implicit_schemes, only: implicit_scheme_t, implicit_solver_report, &
                                implicit_restore_columns
    use explicit_schemes, only: pc_scheme_t
    use central_difference, only: central_scheme_t
    use critical_step, only: CRITICAL_SAFETY
    use linear_solver, only: factor_t, ls_factor, ls_solve, ls_free, ls_factorization, &
                             ls_auto_reason, ls_set_threads, ls_threads
    use trace_output, only: make_dirs, trace_t, trace_open, trace_reopen, trace_row, trace_flush, &
                            trace_sync, trace_close, trace_size, json_real, json_string, &
                            TRACE_ROW_BYTES
    use os_files, only: lock_take, lock_release, check_writable, file_rename, file_remove, &
                        write_text_atomic, free_space, remove_matching, same_folder
    use stop_signal, only: signal_caught, check_stop
    use sparse, only: csc_t
    use cholmod, only: chol_blas
    use vtk_output, only: vtk_write_vtu, vtk_write_pvd, vtk_vtu_bytes
    use version_info, only: DYNCONTACT_VERSION, DYNCONTACT_ISA
    use byte_buffer, only: byte_buffer_t, buf_put, buf_get, buf_put_text, buf_get_text, buf_from
    use checkpoint_file, only: CHECKPOINT_NAME, checkpoint_scene_hash, checkpoint_mesh_hash, &
                               checkpoint_write, checkpoint_read
    implicit none
    private

    !> Expected trace size (bytes) above which the size is announced before the run.
    integer(i8), parameter, public :: BIG_TRACE_BYTES = 100000000_i8
    real(dp), parameter :: FLUSH_S = 1.0_dp      !! trace rows written at least this often (s)
    real(dp), parameter :: SUMMARY_S = 5.0_dp    !! summary.json rewritten this often (s)

    !> One simulation (owned by the caller; no module state).
    type, public :: simulation_t
        integer :: n_dofs = 0                      !! free dofs
        integer :: n_cells = 0                     !! elements
        integer :: n_contact = 0                   !! contact facets
        integer(i8) :: n_steps = 0                 !! steps to reach t_end
        integer(i8) :: step = 0                    !! steps done
        logical :: finished = .false.              !! t_end reached or stopped
        character(len=32) :: status = 'ok'         !! ok | running | unstable | newton_failed | interrupted | write_failed
        character(len=512) :: message = ''         !! why the run stopped early
        !> How the caller stopped the run before its end, when not by an interrupt (a
        !> Python callback that raised): the head of its message; '' = 'interrupted'.
        character(len=384) :: stop_head = ''
        !> The output folder as messages name it when it cannot be made ('--out DIR');
        !> '' = the scene's &output dir (sim_open).
        character(len=:), allocatable :: out_said
        type(scene_t) :: scn                       !! the scene
        type(model_t) :: mdl                       !! the model
        class(time_scheme_t), allocatable :: scheme !! the time scheme
        type(state_t) :: st                        !! current state
        logical :: outputs = .false.               !! outputs open
        logical :: locked = .false.                !! we hold the output folder's lock
        type(trace_t) :: trace                     !! trace.csv
        real(dp) :: e0 = 0.0_dp                    !! e_total(0)
        logical :: has_load = .false.              !! L /= 0 (the test energy includes -u.L)
        !> Numeric factorizations the set-up made outside the scheme (the blow-up limit's
        !> load energy: 1 with a load, else 0); the scheme counts its own.
        integer :: setup_factorizations = 0
        real(dp) :: e_limit = 0.0_dp               !! blow-up threshold of the test energy
        integer(i8) :: clock0 = 0                  !! wall clock at open
        integer(i8) :: clock_rate = 1              !! ticks per second
        integer(i8) :: clock_flush = 0             !! clock of the last trace write
        integer(i8) :: clock_summary = 0           !! clock of the last summary.json
        integer :: n_snap = 0                      !! field snapshots written
        real(dp), allocatable :: snap_t(:)         !! their times
        character(len=64), allocatable :: snap_file(:) !! their file names
        logical :: pvd_due = .false.               !! snapshots written since fields.pvd was
        integer(i8) :: clock_pvd = 0               !! clock of the last fields.pvd write
        integer(i8) :: scene_hash = 0              !! hash of the parsed scene (checkpoints)
        integer(i8) :: restart_step = -1           !! the step the run restarted from (-1: none)
        logical :: auto_dt = .false.               !! dt chosen by the scheme (&scheme dt = 0)
        !> The trace's bytes before its last row when that row is off the rows' grid (the
        !> step count not a multiple of &output every: a row for the end only); -1 else.
        !> A checkpoint at the last step counts only these (sim_checkpoint_save), so that
        !> a longer run continues from it with its own rows; end_row writes the row again.
        integer(i8) :: end_bytes = -1
    end type simulation_t

    public :: sim_open, sim_open_scene, sim_advance, sim_close, sim_trace_bytes, &
              sim_checkpoint_save, sim_checkpoint_load, sim_save, sim_load, sim_stopped_by

contains

    !> Read the scene, build the model, open the outputs (nothing is overwritten
    !> before this succeeds) and write the t = 0 row. `out_dir` /= '' overrides &output dir.
    !> `restart` /= '': continue the run from the checkpoint in that folder (which is
    !> then the output folder) instead of starting at t = 0. `out_said`: how messages
    !> name the output folder when it cannot be made (the caller's option and the
    !> folder, '--out DIR'); absent or '': the scene's key, 'SCENE: &output dir: DIR'.
    subroutine sim_open(sim, scene_path, out_dir, write_output, stat, errmsg, restart, &
                        out_said)
        type(simulation_t), intent(out) :: sim              !! the run
        character(len=*), intent(in) :: scene_path          !! scene file
        character(len=*), intent(in) :: out_dir             !! output folder override ('' = scene's)
        logical, intent(in) :: write_output                 !! .false.: build the model only
        integer, intent(out) :: stat                        !! STAT_OK, STAT_BAD_INPUT, ...
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=*), intent(in), optional :: restart   !! folder of the checkpoint ('' = none)
        character(len=*), intent(in), optional :: out_said  !! the output folder in messages
        type(scene_t) :: scn
        character(len=:), allocatable :: rdir
        rdir = ''
        if (present(restart)) rdir = trim(restart)
        if (len(rdir) > 0 .and. len_trim(out_dir) > 0) then
            if (.not. same_folder(out_dir, rdir)) then
                call raise(stat, errmsg, STAT_BAD_INPUT, '--restart '//rdir//' continues the'// &
                           ' run in that folder: --out must be the same folder or left out')
                return
            end if
        end if
        if (max(len_trim(out_dir), len(rdir)) > len(scn%out_dir)) then
            call raise(stat, errmsg, STAT_BAD_INPUT, 'output folder: the path is longer than ' &
                       //int_text(int(len(scn%out_dir), i8))//' characters')
            return
        end if
        call scene_read(scene_path, scn, stat, errmsg)
        if (stat /= STAT_OK) return
        if (len_trim(out_dir) > 0) scn%out_dir = out_dir
        if (len(rdir) > 0) scn%out_dir = rdir
        call sim_open_scene(sim, scn, write_output, stat, errmsg, restart=len(rdir) > 0, &
                            out_said=out_said)
    end subroutine sim_open

    !> sim_open for a scene already read and validated (`restart`: continue from the
    !> checkpoint in the scene's output folder; `out_said`: as in sim_open). A stop signal
    !> caught during the set-up (module stop_signal: read between its phases and in its
    !> long loops) gives STAT_INTERRUPTED and the message of the run stopped; a new run's
    !> folder then holds it as stopped before its first step (open_stopped), a restart's
    !> folder is left as it was (its checkpoint still continues it; so too when the stop
    !> comes while the restart solves the checkpoint's contact columns again, before it
    !> writes anything), and a model alone (write_output = .false.) writes nothing.
    subroutine sim_open_scene(sim, scn, write_output, stat, errmsg, restart, out_said)
        type(simulation_t), intent(out) :: sim              !! the run
        type(scene_t), intent(in) :: scn                    !! validated scene
        logical, intent(in) :: write_output                 !! .false.: build the model only
        integer, intent(out) :: stat                        !! STAT_OK, STAT_BAD_INPUT, ...
        character(len=*), intent(inout), optional :: errmsg !! message
        logical, intent(in), optional :: restart            !! continue from the checkpoint
        character(len=*), intent(in), optional :: out_said  !! the output folder in messages
        integer :: n
        logical :: again
        again = .false.
        if (present(restart)) again = restart
        sim%out_said = ''
        if (present(out_said)) sim%out_said = out_said
        call system_clock(sim%clock0, sim%clock_rate)
        sim%scn = scn
        sim%pvd_due = .false.
        sim%scene_hash = checkpoint_scene_hash(scn)
        call set_up(sim, write_output, stat, errmsg)
        if (stat /= STAT_OK) call release_scheme(sim)
        if (stat == STAT_INTERRUPTED) then
            call set_up_interrupted()
            if (write_output .and. .not. again) then
                sim%message = interrupted_message(sim, trim(sim%message), .false.)
                call open_stopped(sim, stat, errmsg)
            else
                call raise(stat, errmsg, STAT_INTERRUPTED, trim(sim%message)//' (nothing written)')
            end if
        end if
        if (stat /= STAT_OK .or. .not. write_output) return
        if (again) then
            call reopen_outputs(sim, stat, errmsg)
        else
            call open_outputs(sim, stat, errmsg)
        end if
        if (stat /= STAT_OK) then
            call release_scheme(sim)
            if (sim%status == 'running' .and. stat == STAT_INTERNAL) &
                call open_write_failed(sim, errmsg)
            if (sim%trace%fd >= 0) then    ! ours: remove it (never another run's)
                call trace_close(sim%trace, n)
                call file_remove(trim(sim%scn%out_dir)//'/trace.csv.tmp')
            end if
            if (sim%locked) call lock_release(sim%scn%out_dir)
            sim%locked = .false.
            sim%outputs = .false.
            if (stat == STAT_INTERRUPTED) then   ! a restart's contact columns: nothing written
                call set_up_interrupted()
                call raise(stat, errmsg, STAT_INTERRUPTED, trim(sim%message)//' (nothing written)')
            end if
            return
        end if
        sim%finished = sim%step >= sim%n_steps

    contains

        !> The run's status and message when a stop signal ended its set-up.
        subroutine set_up_interrupted()
            sim%status = 'interrupted'
            sim%message = 'interrupted by signal '//int_text(int(signal_caught(), i8))// &
                          ' during the set-up'
        end subroutine set_up_interrupted
    end subroutine sim_open_scene

    !> The set-up of a run before its outputs: the mesh and the model, the initial state
    !> and (write_output) the time scheme and the blow-up limit. The stop flag is read
    !> between these phases, and inside them in their long loops: STAT_INTERRUPTED.
    subroutine set_up(sim, write_output, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run (scn set)
        logical, intent(in) :: write_output                 !! .false.: build the model only
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=*), parameter :: WHAT = 'the set-up'
        integer :: n
        real(dp) :: e_load
        logical :: early
        call build_model(sim, stat, errmsg)
        call check_stop(WHAT, stat, errmsg)
        if (stat /= STAT_OK) return
        ! a property of the model, set for a new run and a restart alike (e_load and the
        ! blow-up test energy e_total - u.L use it)
        sim%has_load = any(sim%mdl%load /= 0.0_dp)
        ! dt = 0 (central): the step count is known once the scheme has chosen dt
        if (sim%scn%dt > 0.0_dp) then
            call count_steps(sim, write_output, stat, errmsg)
            if (stat /= STAT_OK) return
        end if
        n = sim%n_dofs
        allocate (sim%st%u(n), sim%st%v(n), sim%st%a(n), sim%st%bu(n), sim%st%ktu(n), &
                  sim%st%mv(n), sim%st%lam(sim%mdl%alm%nl))
        sim%st%lam = 0.0_dp
        call model_initial(sim%mdl, model_params(sim%scn), sim%st%u, sim%st%v)
        call state_eval(sim%mdl, sim%st)
        call model_mass_apply(sim%mdl, sim%st%v, sim%st%mv)
        call model_check_initial(sim%mdl, model_params(sim%scn), sim%st%u, sim%st%v, &
                                 sim%st%mv, sim%st%ktu, sim%st%e_pen, sim%st%e_theta, stat, &
                                 errmsg)
        if (stat /= STAT_OK) return
        sim%st%a = 0.0_dp
        call check_stop(WHAT, stat, errmsg)
        if (stat /= STAT_OK .or. .not. write_output) return
        ! the load's energy of the blow-up limit (a factorization of K + M/t_end^2, freed
        ! at once) before the scheme's factors are made, so that the set-up's peak holds
        ! one of them at a time; with dt = 0 (central) it waits for the step the scheme
        ! chooses, which it reads
        e_load = 0.0_dp
        early = sim%has_load .and. sim%scn%dt > 0.0_dp
        if (early) then
            call load_energy(sim, e_load)
            call check_stop(WHAT, stat, errmsg)
            if (stat /= STAT_OK) return
        end if
        call start_scheme(sim, stat, errmsg)
        call check_stop(WHAT, stat, errmsg)
        if (stat == STAT_OK .and. sim%has_load .and. .not. early) call load_energy(sim, e_load)
        ! the blow-up limit of this scene (its blowup, and its t_end in the load's energy),
        ! from the initial state, for a new run and a restart alike: a raised blowup
        ! continues a run it stopped
        if (stat == STAT_OK) call energy_limit(sim, e_load, stat, errmsg)
        call check_stop(WHAT, stat, errmsg)
    end subroutine set_up

    !> A new run whose set-up a stop signal interrupted (sim%status and message set): its
    !> folder as that of a run stopped before its first step, made and locked, trace.csv
    !> replaced by the trace's header alone (no step made; the previous run's snapshots
    !> and checkpoint removed, as a new run's opening does), summary.json saying
    !> 'interrupted', and the lock released. STAT_INTERRUPTED with the run's message, or
    !> the failure of a write (the folder's lock released).
    subroutine open_stopped(sim, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run (set-up interrupted)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=:), allocatable :: dir
        integer :: st2
        dir = trim(sim%scn%out_dir)
        if (len(sim%out_said) > 0) then
            call make_dirs(dir, stat, errmsg, said=sim%out_said)
        else
            call make_dirs(dir, stat, errmsg, said=trim(sim%scn%path)//': &output dir: '//dir)
        end if
        if (stat == STAT_OK) call take_folder(sim, dir, stat, errmsg)
        if (stat == STAT_OK) call trace_open(dir//'/trace.csv.tmp', sim%trace, stat, errmsg)
        if (stat == STAT_OK) then
            sim%outputs = .true.
            call trace_flush(sim%trace, stat, errmsg)
        end if
        if (stat == STAT_OK) call file_rename(dir//'/trace.csv.tmp', dir//'/trace.csv', &
                                              stat, errmsg)
        if (stat == STAT_OK) then
            sim%trace%path = dir//'/trace.csv'
            call remove_old_outputs(dir, stat, errmsg)
        end if
        if (stat == STAT_OK) then
            sim%finished = .true.
            call sim_close(sim, stat, errmsg)     ! summary.json, the lock released
            if (stat == STAT_OK) call raise(stat, errmsg, STAT_INTERRUPTED, trim(sim%message))
            return
        end if
        if (sim%trace%fd >= 0) then
            call trace_close(sim%trace, st2)
            call file_remove(dir//'/trace.csv.tmp')
        end if
        if (sim%locked) call lock_release(sim%scn%out_dir)
        sim%locked = .false.
        sim%outputs = .false.
    end subroutine open_stopped

    !> The scheme of a run that failed to open: its factors are C memory, which the
    !> deallocation of the run would not release.
    subroutine release_scheme(sim)
        type(simulation_t), intent(inout) :: sim            !! the run
        if (.not. allocated(sim%scheme)) return
        call sim%scheme%free()
        deallocate (sim%scheme)
    end subroutine release_scheme

    !> The mesh and the model of the run's scene, and the run's sizes (a mesh file above
    !> &mesh max_elements is refused).
    subroutine build_model(sim, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run (scn set)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        character(len=1024) :: mmsg
        type(mesh_t) :: msh
        mmsg = ''
        call mesh_load(sim%scn%mesh_file, scene_bar_dim(sim%scn%mesh_dim), &
                       sim%scn%mesh_length, sim%scn%mesh_width, sim%scn%mesh_h, msh, stat, mmsg, &
                       given=geo_given(scene_given(sim%scn, 'mesh', 'h'), &
                                       scene_given(sim%scn, 'mesh', 'length'), &
                                       scene_given(sim%scn, 'mesh', 'width')), &
                       max_elements=sim%scn%max_elements)
        if (stat /= STAT_OK) then
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(sim%scn%path)//': &mesh'// &
                       trim(merge(' file:', ':     ', len_trim(sim%scn%mesh_file) > 0))//' '// &
                       trim(mmsg))
            return
        end if
        call scene_check_dim(sim%scn, msh%dim, stat, errmsg)   ! the vector keys
        if (stat /= STAT_OK) return
        ! a mesh file over the limit is refused before the model allocates its matrices
        if (len_trim(sim%scn%mesh_file) > 0 .and. msh%n_cells > sim%scn%max_elements) then
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(sim%scn%path)//': &mesh file: '// &
                       int_text(int(msh%n_cells, i8))//' elements exceed the limit of '// &
                       int_text(int(sim%scn%max_elements, i8))//' (&mesh max_elements)')
            return
        end if
        call model_build(msh, model_params(sim%scn), sim%mdl, stat, errmsg)
        if (stat /= STAT_OK) return
        if (trim(sim%scn%initial_kind) == 'compressed_bar' .and. sim%scn%amplitude /= 0.0_dp &
            .and. .not. model_lift_length(sim%mdl, model_params(sim%scn)) > 0.0_dp) then
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(sim%scn%path)//': &initial kind:'// &
                       ' ''compressed_bar'' lifts the body over its extent along'// &
                       ' obstacle_normal from the obstacle plane, and the mesh file''s body'// &
                       ' has no node on its side of the plane; give &mesh length or another'// &
                       ' kind (got ''compressed_bar'')')
            return
        end if
        sim%scene_hash = checkpoint_mesh_hash(sim%scene_hash, sim%mdl%msh)
        sim%n_dofs = sim%mdl%n_dofs
        sim%n_cells = sim%mdl%msh%n_cells
        sim%n_contact = sim%mdl%ct%n_facets
    end subroutine build_model

    !> The time scheme of the scene, set up on the initial state; with &scheme dt = 0
    !> (central) the run takes the step the scheme chose, and counts its steps then.
    subroutine start_scheme(sim, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run (model and initial state)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        type(scheme_params_t) :: sprm
        character(len=:), allocatable :: unsafe
        sprm = scheme_params(sim%scn)
        select case (sprm%kind)
        case (SCHEME_PC, SCHEME_PC_HHT, SCHEME_PC_HHT_SEED)
            allocate (pc_scheme_t :: sim%scheme)
        case (SCHEME_CENTRAL)
            allocate (central_scheme_t :: sim%scheme)
        case default
            allocate (implicit_scheme_t :: sim%scheme)
        end select
        ! &solver threads, kept by the factors through the scheme's set-up
        select type (s => sim%scheme)
        type is (implicit_scheme_t)
            call ls_set_threads(s%lu0, sim%scn%solver_threads)
        type is (pc_scheme_t)
            call ls_set_threads(s%ms%lu, sim%scn%solver_threads)
        type is (central_scheme_t)
            call ls_set_threads(s%ms%lu, sim%scn%solver_threads)
        end select
        ! the scheme's matrix values (J0 = M + c K_theta on the model's pattern) and its
        ! vectors (some ten of n), at the least: asked for first, as they are allocated
        ! without a status
        if (.not. has_room(8.0_dp * sim%mdl%stiff%nnz + 80.0_dp * sim%n_dofs)) then
            call raise(stat, errmsg, STAT_INTERNAL, oom_text('the set-up of the time scheme', &
                       'J0 and its vectors, at least '//mb_text(8.0_dp * sim%mdl%stiff%nnz + &
                       80.0_dp * sim%n_dofs), OOM_HINT_MESH))
            return
        end if
        call sim%scheme%init(sim%mdl, sprm, sim%st, stat, errmsg)
        if (stat /= STAT_OK) return
        call check_massless_weight(sim)
        call check_initial_state(sim)
        call check_unused_mesh_size(sim)
        call check_unused_amplitude(sim)
        call check_unused_scheme_keys(sim)
        call check_unused_contact_keys(sim)
        call check_alm_mass(sim)
        call check_explicit_step(sim)
        if (sim%scn%dt == 0.0_dp) then    ! central chose its step: the run uses it
            sim%scn%dt = sim%scheme%dt
            sim%auto_dt = .true.
            ! the estimate is the linear limit at full contact: measured, it is not a safe
            ! bound with Nitsche theta = -1 or 0, nor in 1D whatever the contact (docs/
            ! numerics.md, "Central differences")
            unsafe = 'warning: &scheme dt = 0 picks at most 0.9 x the estimated critical '// &
                     'step, not a safe bound'
            if (sim%mdl%has_contact .and. trim(sim%scn%contact_method) == 'nitsche' .and. &
                sim%scn%nitsche_theta /= 1) then
                sim%mdl%notes = trim(sim%mdl%notes)//unsafe// &
                ' with &contact theta = '//int_text(sim%scn%nitsche_theta)// &
                ' (measured up to 1.3x above the limit at gamma0 = 10, far more at small gamma0:'// &
                ' docs/numerics.md); give dt or use theta = 1'//new_line('a')
            else if (sim%mdl%has_contact .and. sim%mdl%dim == 1) then
                sim%mdl%notes = trim(sim%mdl%notes)//unsafe// &
                ' in 1D (on the 1D bar e_total + e_contact grows 7-10x by t = 15'// &
                ' and some runs go unstable; up to 3x at 0.8 x, 1.17x at 0.7 x: docs/'// &
                'numerics.md); give dt'//new_line('a')
            end if
            call count_steps(sim, .true., stat, errmsg)
            if (stat /= STAT_OK) return
        end if
    end subroutine start_scheme

    !> A warning for an explicit scheme (central, pc, pc_hht, pc_hht_seed) run at a given
    !> &scheme dt above the critical step it estimates (the linear limit at full contact,
    !> Omega_c / omega_max, approached from above by power iteration: a step above the
    !> estimate is above that limit). Such a run goes unstable as soon as the contact is
    !> fully active, often at its first impact, and the blow-up message alone would not
    !> say that the step is the cause. None for an estimate of 0 (pc_hht_seed with
    !> alpha < 0: no step is stable, its blow-up message says so).
    subroutine check_explicit_step(sim)
        type(simulation_t), intent(inout) :: sim            !! the run (scheme set up)
        character(len=:), allocatable :: where, what, auto
        real(dp) :: dt_crit
        select type (s => sim%scheme)
        type is (central_scheme_t)
            dt_crit = s%dt_crit
            what = 'central differences'
            auto = ' or dt = 0'
        type is (pc_scheme_t)
            dt_crit = s%dt_crit
            what = trim(sim%scn%scheme_name)
            auto = ''
        class default
            return
        end select
        if (sim%scn%dt <= 0.0_dp .or. .not. (dt_crit > 0.0_dp)) return
        if (sim%scn%dt <= dt_crit) return
        if (sim%mdl%has_contact) then
            where = ' at full contact: the run is likely to go unstable once the contact'// &
                    ' is active'
        else
            where = ': the run is likely to go unstable'
        end if
        sim%mdl%notes = trim(sim%mdl%notes)// &
            'warning: &scheme dt = '//real_text(sim%scn%dt, 4)//' is '// &
            fixed_text(sim%scn%dt / dt_crit, 2)//' x the critical step of '//what// &
            ', estimated '//real_text(dt_crit, 4)//where//'; give dt <= '// &
            real_text(CRITICAL_SAFETY * dt_crit, 4)//' (0.9 x it)'//auto//' (docs/'// &
            'scenes.md, &scheme)'//new_line('a')
    end subroutine check_explicit_step

    !> A warning for the redistributed mass on a scheme that weighs the internal force
    !> half at t_n and half at t_n+1 (galpha rho_inf = 1, theta theta = 1/2). The massless
    !> contact dofs then solve B(kb u^n + (1 - kb) u^n+1) = L with kb = 1/2, so their
    !> distance to the quasi-static position is multiplied by -kb/(1 - kb) = -1 at every
    !> step: the snap of the first step never settles and their velocity (v_n at the
    !> probe) alternates in sign from step to step for the whole run (docs/numerics.md,
    !> "Mass"). Any other weight damps it (kb = alpha_f = rho_inf/(rho_inf + 1), 1 - theta,
    !> -alpha for hht; 0 for newmark).
    subroutine check_massless_weight(sim)
        type(simulation_t), intent(inout) :: sim            !! the run (scheme set up)
        character(len=:), allocatable :: what, fix
        if (.not. sim%mdl%has_contact .or. trim(sim%scn%mass) /= 'redistributed') return
        select case (trim(sim%scn%scheme_name))
        case ('galpha')
            if (sim%scn%rho_inf < 1.0_dp) return
            what = 'galpha rho_inf = 1'
            fix = 'a rho_inf < 1 (0.8 damps it by 0.8 a step)'
        case ('theta')
            if (sim%scn%time_theta > 0.5_dp) return
            what = 'theta theta = 0.5'
            fix = 'a theta > 0.5 (0.6 damps it by 0.67 a step)'
        case default
            return
        end select
        sim%mdl%notes = trim(sim%mdl%notes)// &
            'warning: &scheme mass = ''redistributed'' with '//what//' weighs the massless'// &
            ' contact dofs half at each end of the step: their distance to the quasi-static'// &
            ' position changes sign at every step and never decays (v_n alternates); use '// &
            fix//' or newmark (docs/numerics.md)'//new_line('a')
    end subroutine check_massless_weight

    !> At most one warning about the initial state a scene did not choose:
    !> - an &initial velocity that the initial kind does not use: a scene that gives a
    !>   velocity but keeps the default kind = 'compressed_bar' (the seed's bar, lifted by
    !>   amplitude) would otherwise start from that state at rest, silently. Only a
    !>   nonzero velocity counts: a zero one is the rest every other kind starts from.
    !> - else, a mesh file with &initial kind not given: the default 'compressed_bar' is
    !>   the seed bar's initial state, u0 = -amplitude (1 - d/length) n, which strains the
    !>   user's body by amplitude/length (50 % with the defaults), silently. Not for the
    !>   built-in bar (the seed's case, whose default it is), nor for a kind written, even
    !>   'compressed_bar' (the user's choice), nor with amplitude = 0 (then u0 = 0).
    subroutine check_initial_state(sim)
        type(simulation_t), intent(inout) :: sim            !! the run
        character(len=:), allocatable :: start, three_digits
        real(dp) :: strain
        if (trim(sim%scn%initial_kind) /= 'velocity' .and. any(sim%scn%velocity /= 0.0_dp) &
            .and. scene_given(sim%scn, 'initial', 'velocity')) then
            if (trim(sim%scn%initial_kind) == 'compressed_bar') then
                start = 'the compressed bar''s u0 = -amplitude (1 - d/length) n'
            else
                start = 'u0 = 0'
            end if
            sim%mdl%notes = trim(sim%mdl%notes)// &
                'warning: &initial velocity is not used with kind = '''// &
                trim(sim%scn%initial_kind)//''': the run starts at rest from '//start// &
                '; kind = ''velocity'' starts with that velocity'//new_line('a')
        else if (len_trim(sim%scn%mesh_file) > 0 .and. sim%scn%amplitude /= 0.0_dp .and. &
                 .not. scene_given(sim%scn, 'initial', 'kind')) then
            ! to 3 digits, written as short as it reads back (2.38E+000, 2.5E-001)
            three_digits = real_text(sim%scn%amplitude / &
                                     model_lift_length(sim%mdl, model_params(sim%scn)), 3)
            read (three_digits, *) strain
            sim%mdl%notes = trim(sim%mdl%notes)// &
                'warning: &initial kind is not given: the mesh file''s body starts from the'// &
                ' default kind = ''compressed_bar'', the seed bar''s u0 = -amplitude (1 -'// &
                ' d/length) n, at rest (compressed by amplitude/length = '// &
                real_text(strain)//' along n); give kind ='// &
                ' ''rest'' or ''velocity'' (with velocity), or ''compressed_bar'' to keep it'// &
                ' (docs/scenes.md, &initial)'//new_line('a')
        end if
    end subroutine check_initial_state

    !> A note for an &mesh h given with a .msh file: the file's mesh is used as it is
    !> (h sizes a .geo or the built-in bar), so a scene that refines a .msh by h would
    !> otherwise run on the coarse mesh, silently.
    !> Also a note for &mesh width, or length, given with a .msh file: they size a .geo
    !> and the built-in bar (length is still used by kind = 'compressed_bar', whose lift
    !> falls to 0 over it).
    subroutine check_unused_mesh_size(sim)
        type(simulation_t), intent(inout) :: sim            !! the run
        character(len=:), allocatable :: unused
        if (lower(file_extension(trim(sim%scn%mesh_file))) /= '.msh') return
        if (scene_given(sim%scn, 'mesh', 'h')) &
            sim%mdl%notes = trim(sim%mdl%notes)//'note: &mesh h = '// &
                real_text(sim%scn%mesh_h)//' is not used: a .msh file is meshed already (h'// &
                ' sizes a .geo and the built-in bar; python -m dyncontact mesh --geo FILE.geo'// &
                ' --h H writes a .msh of size H)'//new_line('a')
        unused = ''
        if (scene_given(sim%scn, 'mesh', 'width')) unused = ', width'
        if (scene_given(sim%scn, 'mesh', 'length') .and. &
            trim(sim%scn%initial_kind) /= 'compressed_bar') unused = unused//', length'
        if (len(unused) > 0) &
            sim%mdl%notes = trim(sim%mdl%notes)//'note: &mesh '//unused(3:)//': not used'// &
                ' with a .msh file, which is meshed already (they size a .geo and the'// &
                ' built-in bar)'//new_line('a')
    end subroutine check_unused_mesh_size

    !> A warning for an &initial amplitude given with a kind other than 'compressed_bar',
    !> the only kind it lifts: it would otherwise change nothing, silently.
    subroutine check_unused_amplitude(sim)
        type(simulation_t), intent(inout) :: sim            !! the run
        if (trim(sim%scn%initial_kind) == 'compressed_bar') return
        if (.not. scene_given(sim%scn, 'initial', 'amplitude')) return
        sim%mdl%notes = trim(sim%mdl%notes)//'warning: &initial amplitude is not used with'// &
            ' kind = '''//trim(sim%scn%initial_kind)//''' (it lifts the ''compressed_bar'''// &
            ' state; docs/scenes.md, &initial)'//new_line('a')
    end subroutine check_unused_amplitude

    !> A warning for the &scheme parameters given (whatever their values, the defaults
    !> included) that the chosen scheme does not use (hht with beta or gamma, whose beta
    !> and gamma follow from alpha; newmark with alpha, ...): they would otherwise change
    !> nothing, silently.
    subroutine check_unused_scheme_keys(sim)
        type(simulation_t), intent(inout) :: sim            !! the run
        character(len=:), allocatable :: used, unused
        character(len=8), parameter :: PARAMS(5) = [character(len=8) :: 'alpha', 'beta', &
                                                     'gamma', 'theta', 'rho_inf']
        integer :: k
        used = ''
        select case (trim(sim%scn%scheme_name))
        case ('newmark', 'pc')
            used = 'beta, gamma'
        case ('hht', 'hht_seed', 'pc_hht', 'pc_hht_seed')
            used = 'alpha'
        case ('theta')
            used = 'theta'
        case ('galpha')
            used = 'rho_inf'
        end select
        unused = ''
        do k = 1, size(PARAMS)
            if (index(used, trim(PARAMS(k))) == 0 .and. &
                scene_given(sim%scn, 'scheme', trim(PARAMS(k)))) &
                unused = unused//', '//trim(PARAMS(k))
        end do
        if (len(unused) == 0) return
        if (len(used) == 0) used = 'none of them'
        sim%mdl%notes = trim(sim%mdl%notes)//'warning: &scheme '//unused(3:)// &
            ': not used by scheme '''//trim(sim%scn%scheme_name)//''' (it uses '//used// &
            '; docs/scenes.md, &scheme)'//new_line('a')
    end subroutine check_unused_scheme_keys

    !> A warning for the &contact keys given (whatever their values) that the chosen
    !> method or quadrature does not use: the Nitsche theta with 'penalty' or 'alm',
    !> multiplier without 'alm', quad_points with quadrature = 'exact'.
    subroutine check_unused_contact_keys(sim)
        type(simulation_t), intent(inout) :: sim            !! the run
        character(len=:), allocatable :: method
        if (.not. sim%mdl%has_contact) return
        method = trim(sim%scn%contact_method)
        if (method /= 'nitsche' .and. scene_given(sim%scn, 'contact', 'theta')) &
            sim%mdl%notes = trim(sim%mdl%notes)//'warning: &contact theta: not used by '// &
            'method = '''//method//''' (the Nitsche variant; docs/scenes.md, &contact)'// &
            new_line('a')
        if (method /= 'alm' .and. scene_given(sim%scn, 'contact', 'multiplier')) &
            sim%mdl%notes = trim(sim%mdl%notes)//'warning: &contact multiplier: not used by '// &
            'method = '''//method//''' (only ''alm'' has multipliers; docs/scenes.md, '// &
            '&contact)'//new_line('a')
        if (trim(sim%scn%quadrature) == 'exact' .and. sim%mdl%dim > 1 .and. &
            scene_given(sim%scn, 'contact', 'quad_points')) &
            sim%mdl%notes = trim(sim%mdl%notes)//'warning: &contact quad_points: not used '// &
            'with quadrature = ''exact'' (it splits each facet at the kink; quad_points is '// &
            'for quadrature = ''gauss''; docs/scenes.md, &contact)'//new_line('a')
    end subroutine check_unused_contact_keys

    !> A warning for the augmented Lagrangian with a mass that has inertia on the contact
    !> nodes (consistent, the default, or lumped): the multipliers chatter at every impact
    !> and their work raises the energy several-fold, and most runs blow up
    !> (docs/numerics.md, "Which method, with which mass"); the redistributed mass is the
    !> one it is meant for.
    subroutine check_alm_mass(sim)
        type(simulation_t), intent(inout) :: sim            !! the run
        if (.not. sim%mdl%has_contact .or. trim(sim%scn%contact_method) /= 'alm' .or. &
            trim(sim%scn%mass) == 'redistributed') return
        sim%mdl%notes = trim(sim%mdl%notes)//'warning: &contact method = ''alm'' with '// &
            '&scheme mass = '''//trim(sim%scn%mass)//''': the multipliers chatter at the'// &
            ' impacts and the energy grows several-fold (most runs blow up); use mass ='// &
            ' ''redistributed'' (docs/numerics.md, "Which method, with which mass")'// &
            new_line('a')
    end subroutine check_alm_mass

    !> The outputs were opened (trace.csv and the first summary.json replaced the
    !> previous run's) but a later write of the opening failed (the t = 0 snapshot on a
    !> full disk): summary.json says so, as it does for a write failed during the run.
    subroutine open_write_failed(sim, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run (outputs opened)
        character(len=*), intent(in), optional :: errmsg    !! message of the failed write
        integer :: st2
        character(len=512) :: msg2
        sim%status = 'write_failed'
        sim%message = ''
        if (present(errmsg)) sim%message = errmsg
        sim%finished = .true.
        call write_summary(sim, st2, msg2, last=.true.)
    end subroutine open_write_failed

    !> Output folder, lock, checks that every target can be written, then the new
    !> trace under a temporary name; it replaces trace.csv only once its t = 0 row
    !> and the first summary.json are written (previous results are kept until then).
    subroutine open_outputs(sim, st, msg)
        type(simulation_t), intent(inout) :: sim            !! the run (scheme set up)
        integer, intent(out) :: st                          !! status
        character(len=*), intent(inout), optional :: msg    !! message
        character(len=:), allocatable :: dir
        dir = trim(sim%scn%out_dir)
        if (len(sim%out_said) > 0) then
            call make_dirs(dir, st, msg, said=sim%out_said)
        else
            call make_dirs(dir, st, msg, said=trim(sim%scn%path)//': &output dir: '//dir)
        end if
        if (st /= STAT_OK) return
        call take_folder(sim, dir, st, msg)
        if (st == STAT_OK .and. sim%scn%fields_every > 0) &
            call check_writable(dir//'/fields.pvd', st, msg)
        if (st == STAT_OK) call check_space(sim, dir, st, msg)
        if (st /= STAT_OK) return
        call trace_open(dir//'/trace.csv.tmp', sim%trace, st, msg)
        if (st /= STAT_OK) return
        sim%outputs = .true.
        call record(sim, sim%e0, stat=st, errmsg=msg)
        if (st == STAT_OK) call trace_flush(sim%trace, st, msg)
        if (st /= STAT_OK) return
        sim%status = 'running'
        call write_summary(sim, st, msg)
        if (st /= STAT_OK) return
        call file_rename(dir//'/trace.csv.tmp', dir//'/trace.csv', st, msg)
        if (st /= STAT_OK) return
        sim%trace%path = dir//'/trace.csv'
        call system_clock(sim%clock_flush)
        sim%clock_summary = sim%clock_flush
        call remove_old_outputs(dir, st, msg)
        if (st /= STAT_OK) return
        if (sim%scn%fields_every > 0) then
            call make_dirs(dir//'/fields', st, msg)
            if (st /= STAT_OK) return
            allocate (sim%snap_t(sim%n_steps / sim%scn%fields_every + 2), &
                      sim%snap_file(sim%n_steps / sim%scn%fields_every + 2), stat=st)
            if (st /= 0) then
                call raise(st, msg, STAT_BAD_INPUT, trim(sim%scn%path)//': &output '// &
                           'fields_every: no memory for the list of '// &
                           int_text(sim%n_steps / sim%scn%fields_every + 1)//' snapshots')
                return
            end if
            call snapshot(sim, st, msg)
        end if
    end subroutine open_outputs

    !> A new run's folder holds no earlier run's field snapshots or checkpoint:
    !> fields/step_*.vtu (and the temporary .vtu.tmp of a killed run), fields.pvd and
    !> checkpoint.bin (and its .tmp) are removed once the new trace has replaced the old
    !> one, so that old snapshots are neither listed nor left beside the new trace, and
    !> `--restart` never finds a checkpoint of a trace that is gone (a restart keeps them:
    !> they are its own).
    subroutine remove_old_outputs(dir, st, msg)
        character(len=*), intent(in) :: dir                 !! output folder
        integer, intent(out) :: st                          !! status
        character(len=*), intent(inout), optional :: msg    !! message
        call file_remove(dir//'/'//CHECKPOINT_NAME)
        call file_remove(dir//'/'//CHECKPOINT_NAME//'.tmp')
        call file_remove(dir//'/fields.pvd')
        call file_remove(dir//'/fields.pvd.tmp')
        call remove_matching(dir//'/fields', 'step_', '.vtu', st, msg)
        if (st == STAT_OK) call remove_matching(dir//'/fields', 'step_', '.vtu.tmp', st, msg)
    end subroutine remove_old_outputs

    !> Take the output folder's lock (sim%locked) and check that trace.csv and
    !> summary.json can be written there: the opening of a new run's outputs and of a
    !> restarted one's.
    subroutine take_folder(sim, dir, st, msg)
        type(simulation_t), intent(inout) :: sim            !! the run
        character(len=*), intent(in) :: dir                 !! output folder (exists)
        integer, intent(out) :: st                          !! status
        character(len=*), intent(inout), optional :: msg    !! message
        call lock_take(dir, st, msg)
        if (st /= STAT_OK) return
        sim%locked = .true.
        call check_writable(dir//'/trace.csv', st, msg)
        if (st == STAT_OK) call check_writable(dir//'/summary.json', st, msg)
    end subroutine take_folder

    !> With field snapshots (fields_every > 0), refuse a run whose outputs cannot fit in
    !> the output folder's file system, before anything is written: the trace
    !> (TRACE_ROW_BYTES a row) and every snapshot (vtk_vtu_bytes, exact) against the
    !> free bytes, the snapshot files against the free file slots (a snapshot at step 0,
    !> every fields_every steps and at the last step). The key named is
    !> the one that thins the larger part. Large field output is announced as a large
    !> trace is. Without fields nothing is refused here: a trace that outgrows the disk
    !> stops the run as a failed write (exit 4) with whole rows kept. A restart (at step
    !> sim%step > 0) counts what it has still to write, to its own t_end.
    subroutine check_space(sim, dir, st, msg)
        type(simulation_t), intent(inout) :: sim            !! the run (model built)
        character(len=*), intent(in) :: dir                 !! output folder
        integer, intent(out) :: st                          !! status
        character(len=*), intent(inout), optional :: msg    !! message
        integer(i8), parameter :: SLACK = 16384_i8   ! summary.json, fields.pvd header
        integer(i8) :: n_snap, snap, fields, trace, free_b, free_f
        character(len=:), allocatable :: key, what
        st = STAT_OK
        if (sim%scn%fields_every <= 0) return
        ! step 0, the multiples of fields_every and the last step; a restart from step
        ! sim%step writes those after it and the last step's again (end_only_snapshot).
        ! Exact for a run that fails too: its failure snapshot (failure_snapshot), at or
        ! after its last grid snapshot and before the end, stands for the end's or the
        ! next grid step's, which it never writes
        n_snap = sim%n_steps / sim%scn%fields_every + 1
        if (mod(sim%n_steps, int(sim%scn%fields_every, i8)) /= 0) n_snap = n_snap + 1
        trace = sim_trace_bytes(sim)
        if (sim%step > 0) then
            n_snap = n_snap - (sim%step / sim%scn%fields_every + 1)
            trace = (sim%n_steps / sim%scn%every - sim%step / sim%scn%every + 1) * &
                    int(TRACE_ROW_BYTES, i8)
        end if
        snap = vtk_vtu_bytes(sim%mdl%dim, sim%mdl%msh%n_nodes, sim%mdl%msh%cells)
        fields = n_snap * (snap + 100_i8)    ! and its line in fields.pvd
        call free_space(dir, free_b, free_f)
        key = merge('fields_every', 'every       ', fields > trace)
        what = 'the run would write about '//bytes_text(trace + fields)//' (the trace '// &
               bytes_text(trace)//', '//int_text(n_snap)//' snapshots of '// &
               bytes_text(snap)//' each)'
        if (free_b >= 0 .and. trace + fields + SLACK > free_b) then
            call raise(st, msg, STAT_BAD_INPUT, trim(sim%scn%path)//': &output '// &
                       trim(key)//': '//what//' but '//dir//' has '//bytes_text(free_b)// &
                       ' free; a larger &output '//trim(key)//' thins it')
        else if (free_f >= 0 .and. n_snap + 8 > free_f) then
            call raise(st, msg, STAT_BAD_INPUT, trim(sim%scn%path)//': &output '// &
                       'fields_every: the run would write '//int_text(n_snap)// &
                       ' snapshot files but '//dir//' has room for '//int_text(free_f)// &
                       ' more files; a larger &output fields_every thins them')
        else if (fields > BIG_TRACE_BYTES) then
            sim%mdl%notes = trim(sim%mdl%notes)//'note: the field snapshots will take about ' &
                //bytes_text(fields)//' ('//int_text(n_snap)//' files; &output fields_every'// &
                ' thins them)'//new_line('a')
        end if
    end subroutine check_space

    !> A byte count as text with a unit: '512 B', '3.4 kB', '1.2 MB', '250.0 GB'.
    function bytes_text(b) result(s)
        integer(i8), intent(in) :: b   !! bytes
        character(len=:), allocatable :: s
        character(len=32) :: buf
        character(len=2), parameter :: UNITS(4) = ['kB', 'MB', 'GB', 'TB']
        integer :: k
        if (b < 1000_i8) then
            s = int_text(b)//' B'
            return
        end if
        k = min(4, int(log10(real(b, dp)) / 3.0_dp))
        write (buf, '(f0.1, 1x, a)') real(b, dp) / 1000.0_dp**k, UNITS(k)
        s = trim(buf)
    end function bytes_text

    !> The outputs of a run continued from its checkpoint: the folder's lock, the state
    !> and counters from checkpoint.bin (refused unless it is this scene's and this
    !> build's, whole and intact), trace.csv cut back to the rows up to the checkpoint's
    !> step and continued, the snapshots listed so far kept.
    subroutine reopen_outputs(sim, st, msg)
        type(simulation_t), intent(inout) :: sim            !! the run (scheme set up)
        integer, intent(out) :: st                          !! status
        character(len=*), intent(inout), optional :: msg    !! message
        character(len=:), allocatable :: dir, path
        integer(i8) :: trace_bytes, size
        logical :: exists
        dir = trim(sim%scn%out_dir)
        path = dir//'/'//CHECKPOINT_NAME
        inquire (file=path, exist=exists)
        if (.not. exists) then
            inquire (file=dir//'/.', exist=exists)
            if (.not. exists) then
                call raise(st, msg, STAT_BAD_INPUT, dir//': no such folder (a restart'// &
                           ' continues a stopped run in its output folder)')
            else if (sim%scn%checkpoint_every > 0) then
                ! the scene writes checkpoints: the run in the folder stopped before its first
                call raise(st, msg, STAT_BAD_INPUT, path//': no checkpoint to restart from (no'// &
                           ' such file; &output checkpoint_every = '// &
                           int_text(int(sim%scn%checkpoint_every, i8))//' writes the first at'// &
                           ' that step: a run stopped before it starts again without --restart)')
            else
                call raise(st, msg, STAT_BAD_INPUT, path//': no checkpoint to restart from (no'// &
                           ' such file; &output checkpoint_every writes one)')
            end if
            return
        end if
        call take_folder(sim, dir, st, msg)
        if (st /= STAT_OK) return
        if (sim%scn%fields_every > 0) allocate (sim%snap_t(sim%n_steps / sim%scn%fields_every + 2), &
                                                sim%snap_file(sim%n_steps / sim%scn%fields_every + 2))
        call sim_checkpoint_load(sim, path, st, msg, trace_bytes)
        if (st /= STAT_OK) return
        inquire (file=dir//'/trace.csv', exist=exists, size=size)
        if (.not. exists .or. size < trace_bytes) then
            call raise(st, msg, STAT_BAD_INPUT, dir//'/trace.csv: missing or shorter than the '// &
                       int_text(trace_bytes)//' bytes written up to the checkpoint; cannot continue it')
            return
        end if
        call check_space(sim, dir, st, msg)     ! the rest of the run, to this t_end
        if (st /= STAT_OK) return
        ! the contact columns the checkpoint's cache held, solved again before anything
        ! in the folder changes: a stop signal during them (STAT_INTERRUPTED) leaves it
        ! as it was, as a stop in the rest of the set-up does
        select type (s => sim%scheme)
        type is (implicit_scheme_t)
            call implicit_restore_columns(s, sim%mdl, st, msg)
        end select
        if (st /= STAT_OK) return
        call trace_reopen(dir//'/trace.csv', trace_bytes, sim%trace, st, msg)
        if (st /= STAT_OK) return
        sim%outputs = .true.
        call end_row(sim, st, msg)
        if (st /= STAT_OK) return
        sim%restart_step = sim%step
        sim%status = 'running'
        call write_summary(sim, st, msg)
        if (st /= STAT_OK) return
        call system_clock(sim%clock_flush)
        sim%clock_summary = sim%clock_flush
        if (sim%scn%fields_every > 0) then
            call make_dirs(dir//'/fields', st, msg)
            ! the snapshots up to the checkpoint (a killed run may have listed later ones)
            ! that are still there (the user may have deleted some since)
            call snapshots_at_checkpoint(sim, st, msg)
        end if
    end subroutine reopen_outputs

    !> The field snapshots as of the loaded checkpoint, for a restart and a Stepper's load
    !> alike: the list keeps those still in the folder (drop_missing_snapshots), the files
    !> of steps after the checkpoint's (fields/step_N.vtu and .vtu.tmp, N > sim%step) are
    !> removed as the trace's rows after it are cut, and fields.pvd is rewritten. A stopped
    !> run may have written snapshots past its last checkpoint, which a restart to an
    !> earlier t_end (or a Stepper gone back to a saved state) does not write again; left
    !> there, they would lie beside the trace as this run's fields at times it never
    !> reached, for anyone who reads fields/ without fields.pvd. The continued run writes
    !> its own. A checkpoint's step off the snapshots' grid (fields_every) has a snapshot
    !> only as the end of a run (the checkpoint does not list it): its file is removed too,
    !> as a longer run has none there, and written again when the step is this run's last
    !> (end_only_snapshot).
    subroutine snapshots_at_checkpoint(sim, st, msg)
        type(simulation_t), intent(inout) :: sim            !! the run (checkpoint loaded)
        integer, intent(out) :: st                          !! status
        character(len=*), intent(inout), optional :: msg    !! message
        character(len=:), allocatable :: fields
        integer(i8) :: after
        call drop_missing_snapshots(sim)
        fields = trim(sim%scn%out_dir)//'/fields'
        after = sim%step
        if (mod(sim%step, int(sim%scn%fields_every, i8)) /= 0) after = sim%step - 1
        call remove_matching(fields, 'step_', '.vtu', st, msg, after=after)
        if (st == STAT_OK) call remove_matching(fields, 'step_', '.vtu.tmp', st, msg, after=after)
        if (st == STAT_OK .and. end_only_snapshot(sim)) call snapshot(sim, st, msg)
        if (st == STAT_OK) call write_pvd(sim, st, msg)
    end subroutine snapshots_at_checkpoint

    !> Whether the run stands at its last step and that step is off the snapshots' grid
    !> (a step count that is not a multiple of &output fields_every): its snapshot is
    !> there for the end only. A checkpoint there does not list it, so that a longer run
    !> continued from it holds the snapshots of a run made straight to its own end; a run
    !> continued to this same end writes it again (snapshots_at_checkpoint), as end_row
    !> does the trace's last row.
    logical function end_only_snapshot(sim)
        type(simulation_t), intent(in) :: sim   !! the run
        end_only_snapshot = .false.
        if (sim%scn%fields_every <= 0 .or. sim%step /= sim%n_steps .or. sim%step == 0) return
        end_only_snapshot = mod(sim%step, int(sim%scn%fields_every, i8)) /= 0
    end function end_only_snapshot

    !> Drop from the list of snapshots that a checkpoint brought back (sim%snap_t,
    !> snap_file) those whose VTU file is no longer in the output folder (deleted between
    !> the runs): fields.pvd is then rewritten to list only files ParaView can open (a
    !> collection with a missing file does not open), and the later checkpoints no longer
    !> count them. A deleted snapshot cannot be written again (the checkpoint holds the
    !> state of its own step only), so it stays missing; one warning line in the run's
    !> notes names the first missing file and counts the others.
    subroutine drop_missing_snapshots(sim)
        type(simulation_t), intent(inout) :: sim            !! the run (snapshot list loaded)
        character(len=:), allocatable :: dir
        character(len=64) :: first
        integer :: k, kept, missing
        logical :: exists
        dir = trim(sim%scn%out_dir)
        kept = 0
        missing = 0
        first = ''
        do k = 1, sim%n_snap
            inquire (file=dir//'/'//trim(sim%snap_file(k)), exist=exists)
            if (exists) then
                kept = kept + 1
                sim%snap_t(kept) = sim%snap_t(k)
                sim%snap_file(kept) = sim%snap_file(k)
            else
                missing = missing + 1
                if (missing == 1) first = sim%snap_file(k)
            end if
        end do
        sim%n_snap = kept
        if (missing == 0) return
        sim%mdl%notes = trim(sim%mdl%notes)//'warning: '//dir//'/'//trim(first)// &
            ' is missing'//others(missing - 1)//': fields.pvd lists only the snapshots'// &
            ' still in the folder (a deleted snapshot is not written again)'//new_line('a')
    contains
        !> ' (and n other snapshots)' after the first missing one's name, or nothing.
        function others(n) result(s)
            integer, intent(in) :: n    !! missing snapshots besides the first
            character(len=:), allocatable :: s
            s = ''
            if (n == 1) s = ' (and 1 other snapshot)'
            if (n > 1) s = ' (and '//int_text(int(n, i8))//' other snapshots)'
        end function others
    end subroutine drop_missing_snapshots

    !> Blow-up threshold (docs/scenes.md, "blow-up test"). Without load it is
    !> blowup x e_total(0) as always (the stored penalty energy when e_total(0) = 0,
    !> e.g. a body at rest starting in the obstacle). With a load L the test energy
    !> is e_total - u.L and the scale |e_total(0) - u0.L| + the stored penalty energy
    !> + the load's energy 1/2 L.(K + M/t_end^2)^{-1} L (the static energy
    !> 1/2 L.K^{-1} L when K dominates; the work of L on the free body over t_end
    !> when K has rigid modes). Never a running maximum (growth must be seen). A limit
    !> that overflows is bad input, as it would turn the test off: the load's energy
    !> (&material gravity) or blowup x the scale (&scheme blowup).
    subroutine energy_limit(sim, e_load, st, msg)
        type(simulation_t), intent(inout) :: sim            !! the run at its initial state
        real(dp), intent(in) :: e_load                      !! load_energy (read with a load)
        integer, intent(out) :: st                          !! status
        character(len=*), intent(inout), optional :: msg    !! message
        real(dp) :: e_tot, e_scale
        st = STAT_OK
        e_tot = 0.5_dp * dot_product(sim%st%v, sim%st%mv) &
                + 0.5_dp * dot_product(sim%st%u, sim%st%ktu) + sim%st%e_theta
        e_scale = e_tot
        if (sim%has_load) then
            e_scale = abs(e_tot - dot_product(sim%st%u, sim%mdl%load)) &
                      + max(sim%st%e_pen, 0.0_dp) + e_load
        else if (.not. e_scale > 0.0_dp) then
            e_scale = max(sim%st%e_pen, 0.0_dp)
        end if
        sim%e_limit = sim%scn%blowup * max(e_scale, tiny(1.0_dp))
        if (ieee_is_finite(sim%e_limit)) return
        if (.not. ieee_is_finite(e_scale)) then
            call raise(st, msg, STAT_BAD_INPUT, trim(sim%scn%path)//': &material gravity: '// &
                       'the load''s energy 1/2 L.(K + M/t_end^2)^-1 L overflows on this mesh '// &
                       '(|gravity| = '//real_text(norm2(sim%scn%gravity), 4)// &
                       ', &material density = '//real_text(sim%scn%density, 4)//')')
        else
            call raise(st, msg, STAT_BAD_INPUT, trim(sim%scn%path)//': &scheme blowup: '// &
                       real_text(sim%scn%blowup, 4)//' x the energy scale '// &
                       real_text(e_scale, 4)//' overflows, which would turn the blow-up '// &
                       'test off; give blowup <= '//real_text(huge(1.0_dp) / e_scale / 10.0_dp, 1))
        end if
    end subroutine energy_limit

    !> Step count in 64 bits, refused above &scheme max_steps (t_end / dt may not even
    !> fit); a note on the trace size when it is large (and outputs are written).
    subroutine count_steps(sim, write_output, st, em)
        type(simulation_t), intent(inout) :: sim            !! the run (scn%dt set)
        logical, intent(in) :: write_output                 !! outputs will be written
        integer, intent(out) :: st                          !! status
        character(len=*), intent(inout), optional :: em     !! message
        real(dp) :: ratio
        st = STAT_OK
        ratio = sim%scn%t_end / sim%scn%dt
        if (.not. ratio - 1.0e-9_dp <= real(sim%scn%max_steps, dp)) then
            call raise(st, em, STAT_BAD_INPUT, trim(sim%scn%path)//': &scheme dt: t_end / dt = ' &
                       //real_text(ratio, 6)//' steps exceed the limit of '// &
                       int_text(int(sim%scn%max_steps, i8))//' (&scheme max_steps)')
            return
        end if
        sim%n_steps = max(0_i8, ceiling(ratio - 1.0e-9_dp, i8))
        if (write_output .and. sim_trace_bytes(sim) > BIG_TRACE_BYTES) then
            sim%mdl%notes = trim(sim%mdl%notes)//'note: the trace will take about '// &
                bytes_text(sim_trace_bytes(sim))//' ('// &
                int_text(sim%n_steps / sim%scn%every + 1_i8)//' rows; &output every thins it)'// &
                new_line('a')
        end if
    end subroutine count_steps

    !> e = 1/2 L.(K + M/t_end^2)^{-1} L (0 if the factorization fails); the factorization
    !> made is added to sim%setup_factorizations.
    subroutine load_energy(sim, e)
        type(simulation_t), intent(inout) :: sim            !! the run (model built)
        real(dp), intent(out) :: e                          !! the load's energy scale
        type(csc_t) :: a
        type(factor_t) :: lu
        real(dp), allocatable :: x(:)
        real(dp) :: c
        integer :: st
        e = 0.0_dp
        c = 1.0_dp / max(sim%scn%t_end, sim%scn%dt)**2
        a = sim%mdl%stiff
        a%val = sim%mdl%stiff%val + c * sim%mdl%mass_val
        allocate (x(sim%n_dofs))
        call ls_factor(lu, a, st)
        if (st == STAT_OK) call ls_solve(lu, a, sim%mdl%load, x, st)
        if (st == STAT_OK) e = 0.5_dp * dot_product(sim%mdl%load, x)
        sim%setup_factorizations = sim%setup_factorizations + lu%factorizations
        call ls_free(lu)
    end subroutine load_energy

    !> Expected size of trace.csv in bytes (rows of typical width).
    function sim_trace_bytes(sim) result(bytes)
        type(simulation_t), intent(in) :: sim   !! an opened run
        integer(i8) :: bytes
        bytes = (sim%n_steps / max(1, sim%scn%every) + 2) * int(TRACE_ROW_BYTES, i8)
    end function sim_trace_bytes

    !> Advance at most max_steps steps. A blow-up or Newton failure stops the run
    !> (finished = .true.) with STAT_NUMERIC; the trace so far is kept, and with field
    !> snapshots the state it stopped at has one (failure_snapshot). A failed write
    !> stops it with STAT_INTERNAL (status write_failed), a caught SIGINT/SIGTERM at
    !> the end of a step with STAT_INTERRUPTED (status interrupted).
    subroutine sim_advance(sim, max_steps, steps_done, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run
        integer, intent(in) :: max_steps                    !! step budget of this call
        integer, intent(out) :: steps_done                  !! steps done in this call
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp) :: e_total, e_test
        logical :: row
        integer(i8) :: clock
        integer :: sig
        character(len=512) :: msg
        character(len=512) :: wmsg
        stat = STAT_OK
        steps_done = 0
        if (.not. sim%outputs) then
            call raise(stat, errmsg, STAT_INTERNAL, 'sim_advance: the run has no outputs open')
            return
        end if
        do while (.not. sim%finished .and. steps_done < max_steps)
            sig = signal_caught()
            if (sig /= 0) then
                stat = STAT_INTERRUPTED
            else
                call sim%scheme%step(sim%mdl, sim%st, stat, msg)
                ! a stop signal caught inside the step (a factorization's ranges of rows,
                ! where conjugate gradients fall back on one): stopped at its start, as
                ! before a step (a step that fails changes no state)
                if (stat == STAT_INTERRUPTED) sig = signal_caught()
            end if
            if (stat == STAT_INTERRUPTED) then
                call stop_interrupted(sim, sig, stat, wmsg)
                if (stat /= STAT_OK) then
                    call write_failed(wmsg)
                    return
                end if
                sim%finished = .true.
                call raise(stat, errmsg, STAT_INTERRUPTED, trim(sim%message))
                return
            end if
            if (stat == STAT_INTERNAL) then
                ! out of memory (errors' oom_text): the trace up to the last step is kept
                sim%status = 'internal_error'
                if (is_oom_text(msg)) sim%status = 'out_of_memory'
                sim%message = trim(msg)//' (the run stopped at t = '// &
                              real_text(sim%st%t, 6)//', trace kept)'
                sim%finished = .true.
                call raise(stat, errmsg, STAT_INTERNAL, trim(sim%message))
                return
            end if
            if (stat /= STAT_OK) then
                sim%status = 'newton_failed'
                sim%message = trim(msg)       ! (it gives t: the schemes' step_failed)
                if (sim%scheme%failure == FAILURE_CG) then
                    sim%message = trim(sim%message)//'; check &solver cg_max_iter and '// &
                                  'cg_rtol, or use &solver kind = ''direct'''
                else
                    sim%message = trim(sim%message)//'; check &scheme dt (smaller), &contact'// &
                                  ' gamma0 (of the order of the material stiffness, '// &
                                  'docs/scenes.md), &scheme newton_tol and newton_maxit (= '// &
                                  int_text(int(sim%scn%newton_maxit, i8))//')'
                end if
                ! the trace ends, as the snapshots do, at the last step accepted (off the
                ! rows' grid its row is written here; the failed step changed no state)
                stat = STAT_OK
                if (mod(sim%step, int(sim%scn%every, i8)) /= 0) &
                    call record(sim, e_total, stat=stat, errmsg=wmsg)
                if (stat == STAT_OK) call failure_snapshot(sim, stat, wmsg)
                if (stat /= STAT_OK) then
                    call write_failed(wmsg)
                    return
                end if
                sim%finished = .true.
                call raise(stat, errmsg, STAT_NUMERIC, trim(sim%message))
                return
            end if
            sim%step = sim%step + 1
            steps_done = steps_done + 1
            sim%st%t = real(sim%step, dp) * sim%scn%dt
            row = mod(sim%step, int(sim%scn%every, i8)) == 0 .or. sim%step == sim%n_steps
            ! the rows before this step's, when its row is there only as the run's end
            if (sim%step == sim%n_steps .and. mod(sim%step, int(sim%scn%every, i8)) /= 0) &
                sim%end_bytes = trace_size(sim%trace)
            call record(sim, e_total, row, stat, wmsg)
            if (stat /= STAT_OK) then
                call write_failed(wmsg)
                return
            end if
            e_test = e_total
            if (sim%has_load) e_test = e_total - dot_product(sim%st%u, sim%mdl%load)
            if (.not. ieee_is_finite(e_test) .or. e_test > sim%e_limit) then
                if (.not. row) call record(sim, e_total, stat=stat, errmsg=wmsg)
                if (stat == STAT_OK) call failure_snapshot(sim, stat, wmsg)
                if (stat /= STAT_OK) then
                    call write_failed(wmsg)
                    return
                end if
                sim%status = 'unstable'
                sim%message = unstable_message(sim, e_total, e_test)
                sim%finished = .true.
                call raise(stat, errmsg, STAT_NUMERIC, trim(sim%message))
                return
            end if
            if (sim%scn%fields_every > 0) then
                if (mod(sim%step, int(sim%scn%fields_every, i8)) == 0 .or. &
                    sim%step == sim%n_steps) then
                    call snapshot(sim, stat, wmsg)
                    if (stat /= STAT_OK) then
                        call write_failed(wmsg)
                        return
                    end if
                end if
            end if
            if (sim%step >= sim%n_steps) sim%finished = .true.
            if (sim%scn%checkpoint_every > 0) then
                ! and at the run's end, from which a restart with a later t_end continues
                if (sim%finished .or. mod(sim%step, int(sim%scn%checkpoint_every, i8)) == 0) &
                    call write_checkpoint(sim, stat, wmsg)
                if (stat /= STAT_OK) then
                    call write_failed(wmsg)
                    return
                end if
            end if
            call system_clock(clock)
            if (real(clock - sim%clock_flush, dp) > FLUSH_S * sim%clock_rate) then
                sim%clock_flush = clock
                call trace_flush(sim%trace, stat, wmsg)
                if (stat == STAT_OK .and. sim%pvd_due) call write_pvd(sim, stat, wmsg)
                if (stat == STAT_OK .and. real(clock - sim%clock_summary, dp) > SUMMARY_S * sim%clock_rate) then
                    sim%clock_summary = clock
                    call write_summary(sim, stat, wmsg)
                end if
                if (stat /= STAT_OK) then
                    call write_failed(wmsg)
                    return
                end if
            end if
        end do

    contains

        !> Stop the run after a failed write (sim_close still tries summary.json).
        subroutine write_failed(m)
            character(len=*), intent(in) :: m   !! the run's message
            sim%status = 'write_failed'
            sim%message = m
            sim%finished = .true.
            call raise(stat, errmsg, STAT_INTERNAL, trim(m))
        end subroutine write_failed
    end subroutine sim_advance

    !> The run stopped by signal sig at the end of a step: status and message, and the
    !> checkpoint of that step when the scene asks for checkpoints.
    subroutine stop_interrupted(sim, sig, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run
        integer, intent(in) :: sig                          !! signal caught
        integer, intent(out) :: stat                        !! status (a failed write)
        character(len=*), intent(inout), optional :: errmsg !! message
        stat = STAT_OK
        sim%status = 'interrupted'
        sim%message = interrupted_message(sim, 'interrupted by signal '//int_text(int(sig, i8)), &
                                          .false.)
        if (sim%scn%checkpoint_every > 0) then
            call write_checkpoint(sim, stat, errmsg)
            if (stat /= STAT_OK) return
            sim%message = interrupted_message(sim, 'interrupted by signal '// &
                                              int_text(int(sig, i8)), .true.)
        end if
    end subroutine stop_interrupted

    !> The message of a run stopped before its end: `head` at t = the state's t, and what
    !> was kept (with the checkpoint: how to continue from it).
    function interrupted_message(sim, head, checkpoint) result(msg)
        type(simulation_t), intent(in) :: sim               !! the run
        character(len=*), intent(in) :: head                !! how it was stopped
        logical, intent(in) :: checkpoint                   !! its checkpoint was written
        character(len=:), allocatable :: msg
        msg = head//' at t = '//real_text(sim%st%t, 6)
        if (checkpoint) then
            msg = msg//' (trace and checkpoint kept: --restart '//trim(sim%scn%out_dir)// &
                  ' continues)'
        else
            msg = msg//' (trace kept)'
        end if
    end function interrupted_message

    !> The message of a run stopped by the blow-up test (docs/scenes.md). The energy and
    !> the limit are written with the digits that tell them apart (the first step past the
    !> limit is often past it by less than a 4-digit form shows: '1.250E-001 exceeds
    !> 1.250E-001').
    function unstable_message(sim, e_total, e_test) result(msg)
        type(simulation_t), intent(in) :: sim               !! the run
        real(dp), intent(in) :: e_total                     !! e_kin + e_el
        real(dp), intent(in) :: e_test                      !! the tested energy
        character(len=:), allocatable :: msg
        character(len=:), allocatable :: what, scale
        real(dp) :: e
        if (sim%has_load) then
            what = 'e_total + e_load'
            scale = 'blowup x energy scale'
            e = e_test
        else if (sim%e0 > 0.0_dp) then
            what = 'e_total'
            scale = 'blowup x e_total(0)'
            e = e_total
        else
            what = 'e_total'
            scale = 'blowup x energy scale'
            e = e_total
        end if
        msg = 'unstable at t = '//real_text(sim%st%t, 6)//': '//what//' = '// &
              distinct_text(e, sim%e_limit)//' exceeds '//scale//' = '// &
              distinct_text(sim%e_limit, e)//' (run stopped, trace kept)'//explicit_step_hint(sim)
        ! no energy at all at t = 0 (no motion, no load, nothing stored in the contact):
        ! the limit is the floor tiny(1.0) and the bare number would not say why
        if (.not. sim%has_load .and. sim%e_limit <= sim%scn%blowup * tiny(1.0_dp)) &
            msg = msg//'; the initial state holds no energy (at rest, no contact energy'// &
                  ' stored: a body at rest inside the obstacle with &contact method = '// &
                  '''alm'', whose multipliers store none, is pushed out with energy made'// &
                  ' from nothing)'
    end function unstable_message

    !> What an unstable explicit run adds to its message: the explicit schemes (pc,
    !> pc_hht, pc_hht_seed, central) are stable only below a critical step, the first
    !> thing to check (a newcomer's step is often an implicit scheme's); each gives its
    !> own estimate of that step (pc_hht_seed with alpha < 0 has none: no step is
    !> stable). '' for the implicit schemes.
    function explicit_step_hint(sim) result(hint)
        type(simulation_t), intent(in) :: sim               !! the run
        character(len=:), allocatable :: hint
        character(len=:), allocatable :: contact
        hint = ''
        contact = trim(merge(' at full contact', '                ', sim%mdl%has_contact))
        select type (s => sim%scheme)
        type is (pc_scheme_t)
            if (s%dt_crit > 0.0_dp) then
                hint = '; '//trim(sim%scn%scheme_name)//' is explicit, stable only below '// &
                       'a critical step, estimated '//real_text(s%dt_crit, 4)//contact// &
                       ' (&scheme dt = '//real_text(sim%scn%dt, 4)//'): try a smaller '// &
                       '&scheme dt'
            else if (s%omega_c == 0.0_dp) then
                hint = '; '//trim(sim%scn%scheme_name)//' is unstable at every step: '// &
                       'gamma = '//real_text(s%gamma, 4)//' < 1/2 - alpha = '// &
                       real_text(0.5_dp - s%alpha, 4)// &
                       ' (docs/numerics.md, "Explicit schemes")'
            else
                hint = '; '//trim(sim%scn%scheme_name)//' is explicit, stable only below a '// &
                       'critical step: try a smaller &scheme dt (it is '// &
                       real_text(sim%scn%dt, 4)//')'
            end if
        type is (central_scheme_t)
            hint = '; central is explicit, stable only below a critical step, estimated '// &
                   real_text(s%dt_crit, 4)//contact
            if (sim%auto_dt) then
                ! the run took its own step already: dt = 0 is no advice here
                hint = hint//' (&scheme dt = 0 took '//real_text(sim%scn%dt, 4)// &
                       ', at most 0.9 x the estimate, which is not a safe bound on this '// &
                       'scene): give a smaller &scheme dt'
            else
                hint = hint//' (&scheme dt = '//real_text(sim%scn%dt, 4)// &
                       '): try a smaller &scheme dt, or dt = 0'
            end if
        end select
    end function explicit_step_hint

    !> x with 4 significant digits, or with as many more as tell it apart from y (up to
    !> the 17 that identify a double).
    function distinct_text(x, y) result(s)
        real(dp), intent(in) :: x   !! the value written
        real(dp), intent(in) :: y   !! the value it is compared with
        character(len=:), allocatable :: s
        integer :: d
        do d = 4, 17
            s = real_text(x, d)
            if (s /= real_text(y, d)) return
        end do
    end function distinct_text

    !> Say why the caller stops the run before its end, when not by an interrupt (a
    !> Python callback that raised): sim_close heads summary.json's message with `head`
    !> ('<head> at t = ... (trace kept)') in place of 'interrupted'; the status stays
    !> 'interrupted' (stopped by its caller). A run that has ended keeps its own.
    subroutine sim_stopped_by(sim, head)
        type(simulation_t), intent(inout) :: sim            !! the run
        character(len=*), intent(in) :: head                !! one line, e.g. 'callback raised ...'
        sim%stop_head = head
    end subroutine sim_stopped_by

    !> Write the last rows and summary.json (when outputs are open), release the
    !> output folder's lock and everything else. A write error is returned (the
    !> summary is still attempted after a failed trace write).
    subroutine sim_close(sim, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer :: st2
        character(len=512) :: msg2
        stat = STAT_OK
        if (sim%outputs) then
            if (.not. sim%finished .and. sim%scn%checkpoint_every > 0) then
                ! stopped between steps by the caller (Ctrl-C in Python): resumable
                call write_checkpoint(sim, stat, errmsg)
                if (stat /= STAT_OK) then
                    sim%status = 'write_failed'
                    if (present(errmsg)) sim%message = errmsg
                    sim%finished = .true.
                end if
            end if
            if (.not. sim%finished) then
                ! stopped by the caller (Ctrl-C in Python): the message the executable
                ! gives; another cause the caller named (sim_stopped_by) heads it instead
                sim%status = 'interrupted'
                if (len_trim(sim%stop_head) > 0) then
                    sim%message = interrupted_message(sim, trim(sim%stop_head), &
                                                      sim%scn%checkpoint_every > 0)
                else
                    sim%message = interrupted_message(sim, 'interrupted', &
                                                      sim%scn%checkpoint_every > 0)
                end if
            end if
            if (sim%status == 'running') sim%status = 'ok'
            if (stat == STAT_OK) then
                call trace_close(sim%trace, stat, errmsg)
            else
                call trace_close(sim%trace, st2, msg2)
            end if
            if (sim%pvd_due) then       ! the snapshots not listed yet (also after a failure)
                if (stat == STAT_OK) then
                    call write_pvd(sim, stat, errmsg)
                else
                    call write_pvd(sim, st2, msg2)
                end if
            end if
            if (stat /= STAT_OK .and. sim%status /= 'write_failed') then
                sim%status = 'write_failed'
                if (present(errmsg)) sim%message = errmsg
            end if
            call write_summary(sim, st2, msg2, last=.true.)
            if (stat == STAT_OK .and. st2 /= STAT_OK) call raise(stat, errmsg, st2, msg2)
            sim%outputs = .false.
        end if
        if (sim%locked) call lock_release(sim%scn%out_dir)
        sim%locked = .false.
        if (allocated(sim%scheme)) call sim%scheme%free()
    end subroutine sim_close

    !> Write the run's checkpoint (output folder, CHECKPOINT_NAME): the trace rows so far
    !> are written and synced first, so that the checkpoint never counts rows the file
    !> does not hold.
    subroutine write_checkpoint(sim, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run (outputs open)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        call trace_sync(sim%trace, stat, errmsg)
        if (stat /= STAT_OK) return
        if (sim%pvd_due) call write_pvd(sim, stat, errmsg)
        if (stat /= STAT_OK) return
        call sim_checkpoint_save(sim, trim(sim%scn%out_dir)//'/'//CHECKPOINT_NAME, stat, errmsg)
    end subroutine write_checkpoint

    !> Save the state the next step needs, with the run's counters, to the checkpoint
    !> file `path` (atomic: see checkpoint_write). The payload, in order: step, t, the
    !> step dt the run takes, e_total(0), the trace's bytes, Newton iterations and
    !> factorizations so far, u, v, a, M v, B(u), K_theta u, the augmented Lagrangian's
    !> multipliers lambda (none without them), the contact state
    !> (active points, e_pen, e_theta, f_n), the last step's Newton iterations, the snapshots
    !> written (times, names; at the last step without the one there for the end only, as
    !> the trace's bytes: end_only_snapshot), what the scheme carries
    !> (time_scheme_t%save), then the CG counters (cg_counters_get).
    subroutine sim_checkpoint_save(sim, path, stat, errmsg)
        type(simulation_t), intent(in) :: sim               !! an open run (scheme set up)
        character(len=*), intent(in) :: path                !! checkpoint file
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        type(byte_buffer_t) :: buf
        integer :: k, n_snap
        integer(i8) :: cg(3)
        if (.not. allocated(sim%scheme)) then
            call raise(stat, errmsg, STAT_INTERNAL, 'checkpoint: the run has no scheme set up')
            return
        end if
        call buf_put(buf, sim%step)
        call buf_put(buf, sim%st%t)
        call buf_put(buf, sim%scn%dt)
        call buf_put(buf, sim%e0)
        ! (at the last step, without a last row off the rows' grid: end_bytes)
        if (sim%step == sim%n_steps .and. sim%end_bytes >= 0) then
            call buf_put(buf, sim%end_bytes)
        else
            call buf_put(buf, sim%trace%bytes)
        end if
        call buf_put(buf, int(sim%scheme%newton_total, i8))
        call buf_put(buf, int(sim%scheme%factorizations, i8))
        call buf_put(buf, sim%st%u)
        call buf_put(buf, sim%st%v)
        call buf_put(buf, sim%st%a)
        call buf_put(buf, sim%st%mv)
        call buf_put(buf, sim%st%bu)
        call buf_put(buf, sim%st%ktu)
        call buf_put(buf, sim%st%lam)
        call buf_put(buf, int(sim%st%active, i8))
        call buf_put(buf, sim%st%e_pen)
        call buf_put(buf, sim%st%e_theta)
        call buf_put(buf, sim%st%f_n)
        call buf_put(buf, int(sim%st%newton_its, i8))
        ! (at the last step, without its snapshot when it is off the grid: end_only_snapshot)
        n_snap = sim%n_snap
        if (end_only_snapshot(sim)) n_snap = n_snap - 1
        call buf_put(buf, int(n_snap, i8))
        do k = 1, n_snap
            call buf_put(buf, sim%snap_t(k))
            call buf_put_text(buf, trim(sim%snap_file(k)))
        end do
        call sim%scheme%save(buf)
        call cg_counters_get(sim, cg)
        do k = 1, size(cg)
            call buf_put(buf, cg(k))
        end do
        call checkpoint_write(path, sim%scene_hash, int(sim%n_dofs, i8), sim%step, buf, stat, errmsg)
    end subroutine sim_checkpoint_save

    !> Save a checkpoint of an open run to `path` (Stepper.save): as the run's own
    !> checkpoints, the trace rows so far are written and synced first, so that the
    !> trace length it records counts every row up to its step (the one sim_load and
    !> --restart cut the trace back to).
    subroutine sim_save(sim, path, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! an open run (scheme set up)
        character(len=*), intent(in) :: path                !! checkpoint file
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        stat = STAT_OK
        if (sim%outputs) call trace_sync(sim%trace, stat, errmsg)
        if (stat == STAT_OK) call sim_checkpoint_save(sim, path, stat, errmsg)
    end subroutine sim_save

    !> Load a checkpoint into an open run (Stepper.load): sim_checkpoint_load, then, as
    !> --restart does, trace.csv cut back to the rows up to the checkpoint's step (the rows
    !> written after the state was saved are dropped, so t never goes backwards in the
    !> trace) and fields.pvd rewritten to list the snapshots the checkpoint counts whose
    !> files are still there (drop_missing_snapshots: a warning in the notes). A
    !> state from beyond the rows this run has written (another run's checkpoint, further
    !> on) cannot be cut back to: the trace is then left as it is.
    subroutine sim_load(sim, path, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! an open run (scheme set up)
        character(len=*), intent(in) :: path                !! checkpoint file
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer(i8) :: trace_bytes
        character(len=:), allocatable :: trace_path
        call sim_checkpoint_load(sim, path, stat, errmsg, trace_bytes)
        if (stat /= STAT_OK .or. .not. sim%outputs) return
        call trace_flush(sim%trace, stat, errmsg)       ! every row so far in the file
        if (stat /= STAT_OK) return
        if (sim%trace%bytes < trace_bytes) return
        trace_path = sim%trace%path
        call trace_close(sim%trace, stat, errmsg)
        if (stat == STAT_OK) call trace_reopen(trace_path, trace_bytes, sim%trace, stat, errmsg)
        if (stat == STAT_OK) call end_row(sim, stat, errmsg)
        if (stat /= STAT_OK) return
        if (sim%scn%fields_every > 0) call snapshots_at_checkpoint(sim, stat, errmsg)
    end subroutine sim_load

    !> The last row of a run continued from a checkpoint at its last step (the trace just
    !> cut back to the checkpoint's rows): a step count that is not a multiple of &output
    !> every has a row at the end that the checkpoint's rows leave out (a checkpoint at
    !> the last step does not count it, so that a longer run continues from there:
    !> end_bytes); written again from the loaded state, as the run wrote it.
    subroutine end_row(sim, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run (state loaded, trace open)
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp) :: e_total
        stat = STAT_OK
        sim%end_bytes = -1
        if (sim%step /= sim%n_steps .or. sim%step == 0) return
        if (mod(sim%step, int(sim%scn%every, i8)) == 0) return
        sim%end_bytes = trace_size(sim%trace)
        call record(sim, e_total, stat=stat, errmsg=errmsg)
    end subroutine end_row

    !> The refusal `msg` of another scene's checkpoint `path`, with the keys by which the
    !> run's scene differs from the scene of summary.json in the checkpoint's folder (the
    !> run that wrote it, unless another run wrote there since), those the checkpoint
    !> compares: a scene edited between the stop and the restart says which key changed.
    !> `msg` as it is when the summary cannot be read or no such key differs (the mesh).
    function other_scene_message(sim, path, msg) result(out)
        type(simulation_t), intent(in) :: sim   !! the run
        character(len=*), intent(in) :: path    !! checkpoint file
        character(len=*), intent(in) :: msg     !! checkpoint_read's refusal
        character(len=:), allocatable :: out
        character(len=*), parameter :: SKIP = ' output.dir output.checkpoint_every '// &
            'mesh.file scheme.t_end scheme.max_steps scheme.blowup scheme.dt '
        character(len=:), allocatable :: summary, text, diff
        integer(i8) :: size
        integer :: unit, ios, k
        logical :: exists
        out = trim(msg)
        k = index(path, '/', back=.true.)
        summary = path(1:k)//'summary.json'
        inquire (file=summary, exist=exists, size=size)
        if (.not. exists .or. size <= 0 .or. size > 10000000_i8) return
        allocate (character(len=size) :: text)
        open (newunit=unit, file=summary, access='stream', form='unformatted', &
              action='read', status='old', iostat=ios)
        if (ios /= 0) return
        read (unit, iostat=ios) text
        close (unit)
        if (ios /= 0) return
        k = index(text, '"scene": {')
        if (k == 0) return
        diff = scene_json_diff(scene_to_json(sim%scn), text(k + 9:), SKIP)
        if (len(diff) == 0) return
        out = trim(path)//': written by another scene: '//diff//' (in '//summary// &
              ', the scene of the run that wrote it; restart with that scene, or start'// &
              ' a new run without --restart); refused'
    end function other_scene_message

    !> Load the state and counters saved by sim_checkpoint_save into an open run of the
    !> same scene (STAT_BAD_INPUT naming the file for another scene's, another build's,
    !> a truncated or corrupt checkpoint; the run is then finished, not to be advanced).
    subroutine sim_checkpoint_load(sim, path, stat, errmsg, trace_bytes)
        type(simulation_t), intent(inout) :: sim            !! an open run (scheme set up)
        character(len=*), intent(in) :: path                !! checkpoint file
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        integer(i8), intent(out), optional :: trace_bytes   !! the trace's bytes at the checkpoint
        type(byte_buffer_t) :: buf
        character(len=:), allocatable :: payload
        integer(i8) :: step, k8, tb, its, facts, act, nits, nsnap, cg(3)
        real(dp) :: t, dt
        integer :: k
        if (.not. allocated(sim%scheme)) then
            call raise(stat, errmsg, STAT_INTERNAL, 'checkpoint: the run has no scheme set up')
            return
        end if
        ! a failed load leaves the run stopped (finished: never advanced, no checkpoint
        ! written over the file at close)
        sim%finished = .true.
        call checkpoint_read(path, sim%scene_hash, int(sim%n_dofs, i8), payload, step, stat, errmsg)
        if (stat /= STAT_OK) then
            if (present(errmsg)) then
                if (index(errmsg, ': written by another scene or mesh') > 0) &
                    errmsg = other_scene_message(sim, path, errmsg)
            end if
            return
        end if
        buf = buf_from(payload)
        call buf_get(buf, k8)
        call buf_get(buf, t)
        call buf_get(buf, dt)
        if (k8 /= step .or. step < 0 .or. buf%bad) then
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(path)//': corrupt checkpoint (its'// &
                       ' contents do not fit this run); refused')
            return
        end if
        ! the scene hash leaves dt out (central's dt = 0 takes a step that divides t_end):
        ! the step taken must be the same, bit for bit
        if (dt /= sim%scn%dt) then
            call raise(stat, errmsg, STAT_BAD_INPUT, other_dt_message(sim, path, dt))
            return
        end if
        if (step > sim%n_steps) then
            call raise(stat, errmsg, STAT_BAD_INPUT, past_end_message(sim, path, step, t))
            return
        end if
        sim%step = k8
        sim%st%t = t
        call buf_get(buf, sim%e0)
        call buf_get(buf, tb)
        call buf_get(buf, its)
        call buf_get(buf, facts)
        call buf_get(buf, sim%st%u)
        call buf_get(buf, sim%st%v)
        call buf_get(buf, sim%st%a)
        call buf_get(buf, sim%st%mv)
        call buf_get(buf, sim%st%bu)
        call buf_get(buf, sim%st%ktu)
        call buf_get(buf, sim%st%lam)
        call buf_get(buf, act)
        call buf_get(buf, sim%st%e_pen)
        call buf_get(buf, sim%st%e_theta)
        call buf_get(buf, sim%st%f_n)
        sim%st%clear = .false.      ! (not in the checkpoint: not known at the loaded u)
        call buf_get(buf, nits)
        call buf_get(buf, nsnap)
        if (nsnap < 0) buf%bad = .true.
        if (nsnap > 0) then
            if (.not. allocated(sim%snap_t)) then
                buf%bad = .true.
            else if (nsnap > size(sim%snap_t)) then
                buf%bad = .true.
            end if
        end if
        if (.not. buf%bad) then
            sim%n_snap = int(nsnap)
            do k = 1, sim%n_snap
                call buf_get(buf, sim%snap_t(k))
                call buf_get_text(buf, sim%snap_file(k))
            end do
        end if
        if (.not. buf%bad) call sim%scheme%load(buf)
        do k = 1, size(cg)
            call buf_get(buf, cg(k))
        end do
        if (any(cg < 0)) buf%bad = .true.
        if (buf%bad .or. buf%pos /= buf%n) then
            call raise(stat, errmsg, STAT_BAD_INPUT, trim(path)//': corrupt checkpoint (its'// &
                       ' contents do not fit this run); refused')
            return
        end if
        sim%scheme%newton_total = int(its)
        sim%scheme%factorizations = int(facts)
        call cg_counters_set(sim, cg)
        sim%st%active = int(act)
        sim%st%newton_its = int(nits)
        sim%finished = sim%step >= sim%n_steps
        if (present(trace_bytes)) trace_bytes = tb
    end subroutine sim_checkpoint_load

    !> The refusal of a checkpoint whose run stepped with another dt: the scene hash leaves
    !> dt out so that the step is compared, not the key (with &scheme dt = 0 central takes
    !> the largest step <= 0.9 dt_crit that divides t_end, so another t_end may give
    !> another step; giving the checkpoint's step as dt continues the run).
    function other_dt_message(sim, path, dt) result(msg)
        type(simulation_t), intent(in) :: sim               !! the run
        character(len=*), intent(in) :: path                !! checkpoint file
        real(dp), intent(in) :: dt                          !! the checkpoint's step
        character(len=:), allocatable :: msg
        msg = trim(path)//': written by a run with the step dt = '//real_text(dt)// &
              ', this run''s is '//real_text(sim%scn%dt)
        if (sim%auto_dt) then
            msg = msg//' (&scheme dt = 0: central takes a step that divides &scheme t_end = '// &
                  real_text(sim%scn%t_end)//'; &scheme dt = '//real_text(dt)// &
                  ' continues with the checkpoint''s step)'
        else
            msg = msg//' (&scheme dt)'
        end if
        msg = msg//'; refused'
    end function other_dt_message

    !> The refusal of a checkpoint past the end of the run (a restart continues a run to
    !> the same or a later &scheme t_end, never back).
    function past_end_message(sim, path, step, t) result(msg)
        type(simulation_t), intent(in) :: sim               !! the run (n_steps counted)
        character(len=*), intent(in) :: path                !! checkpoint file
        integer(i8), intent(in) :: step                     !! the checkpoint's step
        real(dp), intent(in) :: t                           !! its time
        character(len=:), allocatable :: msg
        msg = trim(path)//': the checkpoint is at t = '//real_text(t)//' (step '// &
              int_text(step)//'), this run ends at &scheme t_end = '// &
              real_text(sim%scn%t_end)//' (step '//int_text(sim%n_steps)// &
              '): a restart continues to the same or a later t_end; refused'
    end function past_end_message

    !> The CG counters of the implicit schemes' J0 solver (solves, iterations over them,
    !> the most of one solve; zeros for the other schemes and without CG): summary.json's
    !> cg_* numbers, which count the whole run, so they are carried in the checkpoint.
    subroutine cg_counters_get(sim, cg)
        type(simulation_t), intent(in) :: sim   !! the run (scheme set up)
        integer(i8), intent(out) :: cg(3)       !! solves, iterations, max iterations
        cg = 0
        select type (s => sim%scheme)
        type is (implicit_scheme_t)
            cg = [s%lu0%cg%solves, s%lu0%cg%iterations, int(s%lu0%cg%max_its, i8)]
        end select
    end subroutine cg_counters_get

    !> Set the counters cg_counters_get returned (a run continued from a checkpoint).
    subroutine cg_counters_set(sim, cg)
        type(simulation_t), intent(inout) :: sim   !! the run (scheme set up)
        integer(i8), intent(in) :: cg(3)           !! solves, iterations, max iterations
        select type (s => sim%scheme)
        type is (implicit_scheme_t)
            s%lu0%cg%solves = cg(1)
            s%lu0%cg%iterations = cg(2)
            s%lu0%cg%max_its = int(cg(3))
        end select
    end subroutine cg_counters_set

    !> The model's parameters from a validated scene (the one place they are read).
    function model_params(scn) result(p)
        type(scene_t), intent(in) :: scn   !! validated scene
        type(model_params_t) :: p
        p%name = scn%path
        p%mesh_name = mesh_label(scn%mesh_file)
        p%clamped = scn%clamped; p%slip_x = scn%slip_x; p%slip_y = scn%slip_y; p%slip_z = scn%slip_z
        p%contact = scn%contact
        p%young = scn%young; p%poisson = scn%poisson; p%density = scn%density
        p%gravity = scn%gravity
        select case (trim(scn%mass))
        case ('lumped')
            p%mass = MASS_LUMPED
        case ('redistributed')
            p%mass = MASS_REDISTRIBUTED
        case default
            p%mass = MASS_CONSISTENT
        end select
        p%penalty = scn%contact_method == 'penalty'
        p%multiplier = ALM_OFF
        if (scn%contact_method == 'alm') &
            p%multiplier = merge(ALM_NODAL, ALM_INTEGRAL, scn%multiplier == 'nodal')
        p%nitsche_theta = scn%nitsche_theta
        p%gamma0 = scn%gamma0
        p%obstacle_point = scn%obstacle_point; p%obstacle_normal = scn%obstacle_normal
        p%probe = scn%probe
        p%probe_given = scene_given(scn, 'contact', 'probe')
        p%quadrature = merge(QUAD_GAUSS, QUAD_EXACT, scn%quadrature == 'gauss')
        p%quad_points = scn%quad_points
        select case (trim(scn%initial_kind))
        case ('velocity')
            p%initial = INITIAL_VELOCITY
        case ('compressed_bar')
            p%initial = INITIAL_COMPRESSED_BAR
        case default
            p%initial = INITIAL_REST
        end select
        p%amplitude = scn%amplitude
        p%velocity = scn%velocity
        p%length = scn%mesh_length
        ! a mesh file's body has its own length (a .geo that defines it, any .msh), which
        ! &mesh length knows only when the scene gives it
        p%length_from_mesh = len_trim(scn%mesh_file) > 0 .and. &
            .not. scene_given(scn, 'mesh', 'length')
    end function model_params

    !> The scheme's parameters from a validated scene (the scheme chosen once, by kind).
    function scheme_params(scn) result(p)
        type(scene_t), intent(in) :: scn   !! validated scene
        type(scheme_params_t) :: p
        p%kind = scheme_kind(scn%scheme_name)
        p%dt = scn%dt
        p%t_end = scn%t_end
        p%alpha = scn%alpha; p%beta = scn%beta; p%gamma = scn%gamma
        p%theta = scn%time_theta; p%rho_inf = scn%rho_inf
        p%newton_tol = scn%newton_tol; p%newton_maxit = scn%newton_maxit
        p%solver_kind = trim(scn%solver_kind)
        p%cg_rtol = scn%cg_rtol; p%cg_max_iter = scn%cg_max_iter
    end function scheme_params

    !> Energies and probe values of the current state; a trace row when `row`
    !> is absent or true. e_total = e_kin + e_el is returned.
    subroutine record(sim, e_total, row, stat, errmsg)
        type(simulation_t), intent(inout) :: sim   !! the run
        real(dp), intent(out) :: e_total           !! e_kin + e_el
        logical, intent(in), optional :: row       !! write the row (default yes)
        integer, intent(out) :: stat               !! status (a failed write)
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp) :: e_kin, e_el, e_contact, un, vn, pn, e_load
        stat = STAT_OK
        e_kin = 0.5_dp * dot(sim%st%v, sim%st%mv)
        e_el = 0.5_dp * dot(sim%st%u, sim%st%ktu) + sim%st%e_theta
        e_contact = sim%st%e_pen - sim%st%e_theta
        e_total = e_kin + e_el
        if (present(row)) then
            if (.not. row) return
        end if
        e_load = 0.0_dp
        if (sim%has_load) e_load = 0.0_dp - dot(sim%st%u, sim%mdl%load)   ! +0, not -0
        call model_probe(sim%mdl, sim%st%u, sim%st%v, un, vn, pn, sim%st%lam, sim%st%clear)
        call trace_row(sim%trace, sim%st%t, un, vn, pn, e_kin, e_el, e_contact, e_total, &
                       sim%st%newton_its, sim%st%active, e_load, sim%st%f_n, stat, errmsg)
    end subroutine record

    !> Write a VTU snapshot of the current displacement and velocity (under a temporary
    !> name, then renamed: the folder never holds part of a VTU file) and list it in
    !> fields.pvd: at once when the last fields.pvd write is FLUSH_S old or more, else at
    !> the run's next flush (as the trace rows), checkpoint or close (write_pvd).
    subroutine snapshot(sim, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        real(dp), allocatable :: uf(:, :), vf(:, :)
        character(len=64) :: name
        character(len=:), allocatable :: path
        integer(i8) :: clock
        allocate (uf(sim%mdl%dim, sim%mdl%msh%n_nodes), vf(sim%mdl%dim, sim%mdl%msh%n_nodes))
        call model_full_field(sim%mdl, sim%st%u, uf)
        call model_full_field(sim%mdl, sim%st%v, vf)
        name = snapshot_name(sim%step)
        path = trim(sim%scn%out_dir)//'/'//trim(name)
        call vtk_write_vtu(path//'.tmp', sim%mdl%dim, sim%mdl%msh%x, sim%mdl%msh%cells, uf, vf, &
                           stat, errmsg)
        if (stat == STAT_OK) call file_rename(path//'.tmp', path, stat, errmsg)
        if (stat /= STAT_OK) then
            call file_remove(path//'.tmp')
            return
        end if
        sim%n_snap = sim%n_snap + 1
        sim%snap_t(sim%n_snap) = sim%st%t
        sim%snap_file(sim%n_snap) = name
        sim%pvd_due = .true.
        call system_clock(clock)
        if (sim%n_snap == 1 .or. real(clock - sim%clock_pvd, dp) > FLUSH_S * sim%clock_rate) &
            call write_pvd(sim, stat, errmsg)
    end subroutine snapshot

    !> The snapshot file of step `step`, relative to the output folder:
    !> fields/step_NNNNNNN.vtu (7 digits or more).
    pure function snapshot_name(step) result(name)
        integer(i8), intent(in) :: step     !! the run's step
        character(len=64) :: name
        write (name, '(a, i0.7, a)') 'fields/step_', step, '.vtu'
    end function snapshot_name

    !> With field snapshots (fields_every > 0), the snapshot of the state a numerical
    !> failure stopped the run at, unless its step has one already, so that the fields of
    !> the trace's last state can be looked at: after a blow-up, the step whose energy
    !> failed the test (its values as computed, non-finite ones included: the trace's
    !> last row); after a Newton (or linear solve) failure, the last step accepted, as the
    !> iterate of the failed step is no state of the scheme. It lies after the run's last
    !> checkpoint, or at it off the snapshots' grid: a restart removes it with the trace's
    !> rows after the checkpoint (snapshots_at_checkpoint). It takes the place of the
    !> snapshots the run does not reach, so check_space's count holds.
    subroutine failure_snapshot(sim, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run (stopped by a failure)
        integer, intent(out) :: stat                        !! status (a failed write)
        character(len=*), intent(inout), optional :: errmsg !! message
        stat = STAT_OK
        if (sim%scn%fields_every <= 0) return
        if (sim%n_snap > 0) then
            if (sim%snap_file(sim%n_snap) == snapshot_name(sim%step)) return
        end if
        call snapshot(sim, stat, errmsg)
    end subroutine failure_snapshot

    !> fields.pvd listing the snapshots written so far (sim%snap_t, snap_file), written
    !> atomically (temporary file + rename). Rewriting the whole list at every snapshot
    !> would cost the square of their number (fields_every = 1 on 6 000 steps: 10 s
    !> against 2.5 s), so snapshot calls it at most every FLUSH_S and the flushes,
    !> checkpoints and the close catch up (pvd_due): after a kill the list is at most
    !> FLUSH_S behind the VTU files, as the trace's rows are.
    subroutine write_pvd(sim, stat, errmsg)
        type(simulation_t), intent(inout) :: sim            !! the run
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        call vtk_write_pvd(trim(sim%scn%out_dir)//'/fields.pvd', sim%snap_t(1:sim%n_snap), &
                           sim%snap_file(1:sim%n_snap), stat, errmsg)
        call system_clock(sim%clock_pvd)
        if (stat == STAT_OK) sim%pvd_due = .false.
    end subroutine write_pvd

    !> summary.json (SPEC section 4), written atomically (temporary file + rename).
    subroutine write_summary(sim, stat, errmsg, last)
        type(simulation_t), intent(in) :: sim               !! the run
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        logical, intent(in), optional :: last               !! the final one: rewrite in place if need be
        integer :: its, facts, cg_max, threads
        integer(i8) :: clock, fnnz, cg_solves, cg_its
        character(len=:), allocatable :: text, dt_crit_line, ordering, skind, snote, fact, areason
        character(len=1), parameter :: nl = new_line('a')
        call system_clock(clock)
        its = 0; facts = 0
        dt_crit_line = ''
        ordering = ''
        fnnz = 0
        if (allocated(sim%scheme)) call sim%scheme%factor_info(ordering, fnnz)
        skind = ''; snote = ''; fact = ''; areason = ''
        cg_solves = 0; cg_its = 0; cg_max = 0
        threads = 1
        if (allocated(sim%scheme)) then
            select type (s => sim%scheme)
            type is (implicit_scheme_t)
                call implicit_solver_report(s, skind, cg_solves, cg_its, cg_max, snote)
                fact = ls_factorization(s%lu0)
                areason = ls_auto_reason(s%lu0)
                threads = ls_threads(s%lu0)
            type is (pc_scheme_t)
                fact = ls_factorization(s%ms%lu)
                threads = ls_threads(s%ms%lu)
            type is (central_scheme_t)
                fact = ls_factorization(s%ms%lu)
                threads = ls_threads(s%ms%lu)
            end select
        end if
        if (allocated(sim%scheme)) then
            its = sim%scheme%newton_total
            facts = sim%scheme%factorizations
            select type (s => sim%scheme)
            type is (central_scheme_t)
                dt_crit_line = '  "dt_crit_estimate": '//json_real(s%dt_crit)//','//nl
            type is (pc_scheme_t)
                dt_crit_line = '  "dt_crit_estimate": '//json_real(s%dt_crit)//','//nl
            end select
        end if
        text = '{'//nl// &
               '  "status": '//json_string(sim%status)//','//nl// &
               '  "message": '//json_string(sim%message)//','//nl// &
               '  "steps": '//int_text(sim%step)//','//nl// &
               '  "t_end_reached": '//json_real(sim%st%t)//','//nl// &
               '  "wall_s": '//json_real(real(clock - sim%clock0, dp) / sim%clock_rate)//','//nl// &
               '  "newton_its_total": '//int_text(int(its, i8))//','//nl// &
               '  "factorizations": '//int_text(int(facts, i8))//','//nl// &
               '  "setup_factorizations": '//int_text(int(sim%setup_factorizations, i8))// &
               ','//nl// &
               '  "dim": '//int_text(int(sim%mdl%dim, i8))//','//nl// &
               '  "dofs": '//int_text(int(sim%n_dofs, i8))//','//nl// &
               '  "elements": '//int_text(int(sim%n_cells, i8))//','//nl// &
               '  "contact_facets": '//int_text(int(sim%n_contact, i8))//','//nl// &
               '  "scheme": '//json_string(sim%scn%scheme_name)//','//nl// &
               dt_crit_line// &
               '  "solver": '//json_string(sim_solver(sim))//','//nl// &
               '  "solve_kernel": '//json_string(sim_kernel(sim))//','//nl// &
               '  "solver_kind": '//json_string(skind)//','//nl// &
               '  "solver_note": '//json_string(snote)//','//nl// &
               '  "auto_reason": '//json_string(areason)//','//nl// &
               '  "cg_solves": '//int_text(cg_solves)//','//nl// &
               '  "cg_iterations": '//int_text(cg_its)//','//nl// &
               '  "cg_max_iterations": '//int_text(int(cg_max, i8))//','//nl// &
               '  "ordering": '//json_string(ordering)//','//nl// &
               '  "factor_nnz": '//int_text(fnnz)//','//nl// &
               '  "factorization": '//json_string(fact)//','//nl// &
               '  "solve_threads": '//int_text(int(threads, i8))//','//nl// &
               '  "matrix_nnz": '//int_text(int(sim%mdl%stiff%nnz, i8))//','//nl// &
               '  "scene": '//scene_to_json(sim%scn)//','//nl// &
               '  "version": '//json_string(DYNCONTACT_VERSION)//','//nl// &
               '  "isa": '//json_string(DYNCONTACT_ISA)//','//nl// &
               '  "blas": '//json_string(chol_blas())//nl//'}'//nl
        call write_text_atomic(trim(sim%scn%out_dir)//'/summary.json', text, stat, errmsg, &
                               in_place=present(last))
    end subroutine write_summary

    !> The solver of the run's linear systems: the backend of the J0 factors (implicit
    !> schemes) or of the M factors (pc and central; 'diagonal' for lumped mass); '' before
    !> the scheme is set up.
    function sim_solver(sim) result(name)
        type(simulation_t), intent(in) :: sim   !! the run
        character(len=:), allocatable :: name
        name = ''
        if (allocated(sim%scheme)) name = sim%scheme%solver()
    end function sim_solver

    !> The triangular solve used with those factors (see ls_kernel); '' before set-up.
    function sim_kernel(sim) result(name)
        type(simulation_t), intent(in) :: sim   !! the run
        character(len=:), allocatable :: name
        name = ''
        if (allocated(sim%scheme)) name = sim%scheme%kernel()
    end function sim_kernel
end module simulation

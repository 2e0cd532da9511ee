!> Flat procedures for f2py (python/dyncontact/_core): c_int / c_double / c_int64_t
!> arguments, explicit shapes, no derived types. A simulation is passed around as
!> an opaque 64-bit handle to a heap object owned by the caller (no module state).
!> Every procedure returns stat (0 = ok, 2 = bad input, 3 = numerical failure,
!> 4 = internal) and a one-line errmsg.

!> Library version string.
subroutine dc_version(version)
    use version_info, only: DYNCONTACT_VERSION
    implicit none
    character(len=32), intent(out) :: version   !! e.g. '0.1.0'
    version = DYNCONTACT_VERSION
end subroutine dc_version

!> For a program only (`python -m dyncontact run`, `mesh`), never the library: from this
!> call on, SIGINT / SIGTERM while gmsh reads or meshes a mesh file end the process at once
!> (exit 130, the executable's one line naming the file) instead of waiting for gmsh. A
!> switch of the process that the program owning it sets once, as the executable installs
!> its signal handlers; not a run's state, since a library caller's process is not the
!> run's to end.
subroutine dc_exit_on_read_signal()
    use os_files, only: exit_on_read_signal
    implicit none
    call exit_on_read_signal()
end subroutine dc_exit_on_read_signal

!> Point SIGINT or SIGTERM (sig) at the stop flag's handler (base/stop_signal.c), for a
!> library caller whose own handler of it raises KeyboardInterrupt, over the core's call
!> that opens a run only: the run's set-up then reads the signal between its phases and
!> stops within a fraction of a second (STAT_INTERRUPTED) instead of after the set-up.
!> The caller puts its own handler back after the call and takes the flag
!> (dc_stop_signal_take). A signal the process ignores stays ignored. err: 0, or errno.
subroutine dc_stop_signals_catch(sig, err)
    use iso_c_binding, only: c_int
    use os_files, only: stop_signals_catch
    implicit none
    integer(c_int), intent(in) :: sig     !! SIGINT or SIGTERM
    integer(c_int), intent(out) :: err    !! 0 or errno
    err = int(stop_signals_catch(int(sig)), c_int)
end subroutine dc_stop_signals_catch

!> The signal the stop flag holds (0 = none), and the flag cleared: after the call that
!> dc_stop_signals_catch covered, once the caller's handlers are back.
subroutine dc_stop_signal_take(sig)
    use iso_c_binding, only: c_int
    use stop_signal, only: signal_take
    implicit none
    integer(c_int), intent(out) :: sig    !! signal number, 0 = none
    sig = int(signal_take(), c_int)
end subroutine dc_stop_signal_take

!> Name a file or a folder (emptied first) that a stop during a gmsh read removes before it
!> ends the process (dc_exit_on_read_signal), until dc_stop_keeps: a temporary file a
!> program wrote before the read. err: 0, or errno (too long, or too many named).
subroutine dc_stop_removes(path, err)
    use iso_c_binding, only: c_int
    use os_files, only: stop_removes
    implicit none
    character(len=*), intent(in) :: path        !! file or folder
    integer(c_int), intent(out) :: err          !! 0 or errno
    integer :: e
    call stop_removes(path, e)
    err = e
end subroutine dc_stop_removes

!> Take back one naming of path by dc_stop_removes.
subroutine dc_stop_keeps(path)
    use os_files, only: stop_keeps
    implicit none
    character(len=*), intent(in) :: path        !! file or folder
    call stop_keeps(path)
end subroutine dc_stop_keeps

!> Begin the guard around the caller's own calls into gmsh (the Python gmsh module): the
!> signal dispositions kept; after dc_exit_on_read_signal, SIGINT / SIGTERM end the
!> process at once (exit 130, the line line_start, the signal's number, line_end).
!> held = 1 when the guard is this call's (end it with dc_gmsh_guard_end), 0 otherwise.
subroutine dc_gmsh_guard_begin(line_start, line_end, held)
    use iso_c_binding, only: c_int
    use os_files, only: gmsh_guard_begin
    implicit none
    character(len=*), intent(in) :: line_start  !! the line before the signal's number
    character(len=*), intent(in) :: line_end    !! the line after it
    integer(c_int), intent(out) :: held         !! 1 = held by this call
    logical :: h
    call gmsh_guard_begin(line_start, line_end, h)
    held = merge(1, 0, h)
end subroutine dc_gmsh_guard_begin

!> Inside the guard, right after gmsh's initialization (it resets some dispositions).
subroutine dc_gmsh_guard_after_init()
    use os_files, only: gmsh_guard_after_init
    implicit none
    call gmsh_guard_after_init()
end subroutine dc_gmsh_guard_after_init

!> End the guard the calling thread began.
subroutine dc_gmsh_guard_end()
    use os_files, only: gmsh_guard_end
    implicit none
    call gmsh_guard_end()
end subroutine dc_gmsh_guard_end

!> Read and validate a scene file; write the parsed scene (defaults filled) as JSON.
!> given: the keys the file writes, 'group.key' separated by blanks.
subroutine dc_scene_dump(path, json_path, given, stat, errmsg)
    use iso_c_binding, only: c_int
    use errors, only: STAT_OK, STAT_INTERNAL
    use scene, only: scene_t, scene_read, scene_to_json, scene_given_names
    implicit none
    character(len=*), intent(in) :: path        !! scene file
    character(len=*), intent(in) :: json_path   !! JSON file to write
    character(len=4096), intent(out) :: given   !! keys given, 'group.key' separated by blanks
    integer(c_int), intent(out) :: stat         !! status
    character(len=512), intent(out) :: errmsg   !! message
    type(scene_t) :: scn
    integer :: unit, ios, st
    errmsg = ''
    given = ''
    call scene_read(path, scn, st, errmsg)
    stat = st
    if (st /= STAT_OK) return
    given = scene_given_names(scn)    ! every key's 'group.key' fits in 4096 characters
    open (newunit=unit, file=json_path, status='replace', action='write', iostat=ios)
    if (ios /= 0) then
        stat = STAT_INTERNAL
        errmsg = trim(json_path)//': cannot write'
        return
    end if
    write (unit, '(a)') scene_to_json(scn)
    close (unit)
end subroutine dc_scene_dump

!> Parse a scene given as text (as dc_scene_dump does a file) and return it as JSON.
!> full = 0 checks only the syntax and the types of the values (for editing a scene);
!> full = 1 also the ranges and the cross-checks. A relative mesh file counts from the
!> current folder. given: the keys the text writes, as in dc_scene_dump.
subroutine dc_scene_text(text, name, full, json, given, stat, errmsg)
    use iso_c_binding, only: c_int
    use errors, only: STAT_OK, STAT_INTERNAL
    use scene, only: scene_t, scene_parse, scene_to_json, scene_given_names
    implicit none
    character(len=*), intent(in) :: text        !! scene text
    character(len=*), intent(in) :: name        !! its name in messages
    integer(c_int), intent(in) :: full          !! 1: full validation, 0: syntax and types
    character(len=32768), intent(out) :: json   !! the scene as JSON
    character(len=4096), intent(out) :: given   !! keys given, 'group.key' separated by blanks
    integer(c_int), intent(out) :: stat         !! status
    character(len=512), intent(out) :: errmsg   !! message
    type(scene_t) :: scn
    integer :: st
    errmsg = ''
    json = ''
    given = ''
    call scene_parse(text, name, '', full /= 0, scn, st, errmsg)
    stat = st
    if (st /= STAT_OK) return
    json = scene_to_json(scn)
    given = scene_given_names(scn)
    if (json(32768:32768) /= ' ') then
        stat = STAT_INTERNAL
        errmsg = 'dc_scene_text: the scene does not fit in 32768 bytes of JSON'
    end if
end subroutine dc_scene_text

!> Check a scene given as text against the dimension of its mesh, as a run does once the
!> mesh is read (scene_check_dim: the vector keys' component counts, &contact quad_points,
!> &mesh dim against a mesh file's): what Scene.validate adds for a mesh file whose
!> dimension the scene leaves to the file (&mesh dim = 0), so that it refuses what the
!> run would. The text is parsed with the full checks first (as dc_scene_text, full = 1).
subroutine dc_scene_check_dim(text, name, dim, stat, errmsg)
    use iso_c_binding, only: c_int
    use errors, only: STAT_OK
    use scene, only: scene_t, scene_parse, scene_check_dim
    implicit none
    character(len=*), intent(in) :: text        !! scene text
    character(len=*), intent(in) :: name        !! its name in messages
    integer(c_int), intent(in) :: dim           !! the mesh's dimension (1, 2 or 3)
    integer(c_int), intent(out) :: stat         !! status
    character(len=512), intent(out) :: errmsg   !! message
    type(scene_t) :: scn
    integer :: st
    errmsg = ''
    call scene_parse(text, name, '', .true., scn, st, errmsg)
    if (st == STAT_OK) call scene_check_dim(scn, int(dim), st, errmsg)
    stat = st
end subroutine dc_scene_check_dim

!> Open a run: read the scene, build the model, open the outputs in out_dir
!> ('' = the scene's &output dir) unless build_only /= 0. out_said: how a message names
!> the output folder when it cannot be made ('' = the scene's &output dir).
subroutine dc_sim_open(path, out_dir, build_only, out_said, handle, n_steps, dofs, elements, &
                       contact_facets, stat, errmsg)
    use iso_c_binding, only: c_int, c_int64_t
    use errors, only: STAT_OK
    use simulation, only: simulation_t
    use api_handles, only: sim_open_handle
    implicit none
    character(len=*), intent(in) :: path         !! scene file
    character(len=*), intent(in) :: out_dir      !! output folder override
    integer(c_int), intent(in) :: build_only     !! 1: model only, no outputs
    character(len=*), intent(in) :: out_said     !! the output folder in messages ('' = the scene's key)
    integer(c_int64_t), intent(out) :: handle    !! opaque run handle (0 on error)
    integer(c_int), intent(out) :: n_steps       !! steps to t_end
    integer(c_int), intent(out) :: dofs          !! free dofs
    integer(c_int), intent(out) :: elements      !! cells
    integer(c_int), intent(out) :: contact_facets !! contact facets
    integer(c_int), intent(out) :: stat          !! status
    character(len=512), intent(out) :: errmsg    !! message
    type(simulation_t), pointer :: sim
    integer :: st
    errmsg = ''
    n_steps = 0; dofs = 0; elements = 0; contact_facets = 0
    call sim_open_handle(path, out_dir, build_only == 0, handle, sim, st, errmsg, &
                         out_said=out_said)
    stat = st
    if (st /= STAT_OK) return
    n_steps = int(min(sim%n_steps, int(huge(n_steps), kind(sim%n_steps))), c_int)  ! full count: dc_sim_info
    dofs = sim%n_dofs
    elements = sim%n_cells
    contact_facets = sim%n_contact
end subroutine dc_sim_open

!> Advance a run by at most max_steps steps.
subroutine dc_sim_advance(handle, max_steps, steps_done, step, finished, stat, errmsg)
    use iso_c_binding, only: c_int, c_int64_t
    use simulation, only: simulation_t, sim_advance
    use api_handles, only: sim_from_handle
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! run handle
    integer(c_int), intent(in) :: max_steps      !! step budget
    integer(c_int), intent(out) :: steps_done    !! steps done in this call
    integer(c_int), intent(out) :: step          !! steps done in all
    integer(c_int), intent(out) :: finished      !! 1 when the run has ended
    integer(c_int), intent(out) :: stat          !! status (3: unstable / Newton failure)
    character(len=512), intent(out) :: errmsg    !! message
    type(simulation_t), pointer :: sim
    integer :: st, done
    errmsg = ''
    call sim_from_handle(handle, sim)
    call sim_advance(sim, max_steps, done, st, errmsg)
    steps_done = done
    step = int(min(sim%step, int(huge(step), kind(sim%step))), c_int)
    finished = merge(1, 0, sim%finished)
    stat = st
end subroutine dc_sim_advance

!> Close a run: write summary.json (if outputs are open) and free it.
subroutine dc_sim_close(handle, stat, errmsg)
    use iso_c_binding, only: c_int, c_int64_t
    use simulation, only: simulation_t, sim_close
    use api_handles, only: sim_from_handle
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! run handle (invalid afterwards)
    integer(c_int), intent(out) :: stat          !! status
    character(len=512), intent(out) :: errmsg    !! message
    type(simulation_t), pointer :: sim
    integer :: st
    errmsg = ''
    call sim_from_handle(handle, sim)
    call sim_close(sim, st, errmsg)
    deallocate (sim)
    stat = st
end subroutine dc_sim_close

!> Say why the caller stops an open run before its end, when not by an interrupt
!> (a Python callback that raised): dc_sim_close then heads summary.json's message
!> with `head` instead of 'interrupted'.
subroutine dc_sim_stopped_by(handle, head)
    use iso_c_binding, only: c_int64_t
    use simulation, only: simulation_t, sim_stopped_by
    use api_handles, only: sim_from_handle
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! run handle
    character(len=*), intent(in) :: head         !! one line, e.g. 'callback raised ...'
    type(simulation_t), pointer :: sim
    call sim_from_handle(handle, sim)
    call sim_stopped_by(sim, head)
end subroutine dc_sim_stopped_by

!> The lines the executable prints on stdout when it opens a run (module run_lines),
!> without its 'dyncontact: ' prefix: the restart line ('' unless the run continues from
!> a checkpoint) and the run's line, naming the scene file and the output folder as given.
subroutine dc_sim_lines(handle, scene_said, out_said, restart, start)
    use iso_c_binding, only: c_int64_t
    use simulation, only: simulation_t
    use api_handles, only: sim_from_handle
    use run_lines, only: start_line, restart_line
    implicit none
    integer(c_int64_t), intent(in) :: handle       !! run handle
    character(len=*), intent(in) :: scene_said     !! the scene file as given
    character(len=*), intent(in) :: out_said       !! the output folder as given
    character(len=1024), intent(out) :: restart    !! restart line ('' for a fresh run)
    character(len=4096), intent(out) :: start      !! the run's line
    type(simulation_t), pointer :: sim
    call sim_from_handle(handle, sim)
    restart = restart_line(sim)
    start = start_line(sim, scene_said, out_said)
end subroutine dc_sim_lines

!> B(u) on the free dofs of an open run.
subroutine dc_sim_eval_b(handle, n, u, b, active)
    use iso_c_binding, only: c_int, c_int64_t, c_double
    use simulation, only: simulation_t
    use api_handles, only: sim_from_handle, sim_eval_b
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! run handle
    integer(c_int), intent(in) :: n              !! free dofs
    real(c_double), intent(in) :: u(n)           !! displacement
    real(c_double), intent(out) :: b(n)          !! B(u)
    integer(c_int), intent(out) :: active        !! active contact quadrature points
    type(simulation_t), pointer :: sim
    integer :: act
    call sim_from_handle(handle, sim)
    call sim_eval_b(sim, u, b, act)
    active = act
end subroutine dc_sim_eval_b

!> Whether no contact point can be active at u (contact_clear: P finite and >= 0 at
!> every contact facet's nodes) on an open run: 1 or 0.
subroutine dc_sim_contact_clear(handle, n, u, clear)
    use iso_c_binding, only: c_int, c_int64_t, c_double
    use kinds, only: dp
    use simulation, only: simulation_t
    use api_handles, only: sim_from_handle
    use nitsche_contact, only: contact_clear
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! run handle
    integer(c_int), intent(in) :: n              !! free dofs
    real(c_double), intent(in) :: u(n)           !! displacement
    integer(c_int), intent(out) :: clear         !! 1: clear, 0: not
    type(simulation_t), pointer :: sim
    logical :: ok
    real(dp) :: e_theta
    call sim_from_handle(handle, sim)
    call contact_clear(sim%mdl%ct, u, ok, e_theta)
    clear = merge(1, 0, ok)
end subroutine dc_sim_contact_clear

!> B'(u) du (generalized derivative) on the free dofs of an open run.
subroutine dc_sim_jacobian_apply(handle, n, u, du, jdu)
    use iso_c_binding, only: c_int, c_int64_t, c_double
    use simulation, only: simulation_t
    use api_handles, only: sim_from_handle, sim_apply_jacobian
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! run handle
    integer(c_int), intent(in) :: n              !! free dofs
    real(c_double), intent(in) :: u(n)           !! linearization point
    real(c_double), intent(in) :: du(n)          !! direction
    real(c_double), intent(out) :: jdu(n)        !! B'(u) du
    type(simulation_t), pointer :: sim
    call sim_from_handle(handle, sim)
    call sim_apply_jacobian(sim, u, du, jdu)
end subroutine dc_sim_jacobian_apply

!> Static solution K u = L of an open run (contact ignored).
subroutine dc_sim_static(handle, n, u, stat, errmsg)
    use iso_c_binding, only: c_int, c_int64_t, c_double
    use simulation, only: simulation_t
    use api_handles, only: sim_from_handle, sim_static
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! run handle
    integer(c_int), intent(in) :: n              !! free dofs
    real(c_double), intent(out) :: u(n)          !! displacement
    integer(c_int), intent(out) :: stat          !! status
    character(len=512), intent(out) :: errmsg    !! message
    type(simulation_t), pointer :: sim
    integer :: st
    errmsg = ''
    call sim_from_handle(handle, sim)
    call sim_static(sim, u, st, errmsg)
    stat = st
end subroutine dc_sim_static

!> Node (1-based) and component (1..dim) of each free dof of an open run.
subroutine dc_sim_dof_map(handle, n, node, comp)
    use iso_c_binding, only: c_int, c_int64_t
    use simulation, only: simulation_t
    use api_handles, only: sim_from_handle, sim_dof_map
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! run handle
    integer(c_int), intent(in) :: n              !! free dofs
    integer(c_int), intent(out) :: node(n)       !! node of each dof
    integer(c_int), intent(out) :: comp(n)       !! component of each dof
    type(simulation_t), pointer :: sim
    integer :: nd(n), cp(n)
    call sim_from_handle(handle, sim)
    call sim_dof_map(sim, nd, cp)
    node = nd
    comp = cp
end subroutine dc_sim_dof_map

!> Solve A x = b with UMFPACK, A given as 1-based COO triplets (duplicates summed).
subroutine dc_umf_solve(n, nnz, rows, cols, vals, b, x, stat, errmsg)
    use iso_c_binding, only: c_int, c_double
    use errors, only: STAT_OK
    use sparse, only: csc_t, csc_from_coo
    use umfpack, only: lu_t, lu_factor, lu_solve, lu_free
    implicit none
    integer(c_int), intent(in) :: n              !! size
    integer(c_int), intent(in) :: nnz            !! triplets
    integer(c_int), intent(in) :: rows(nnz)      !! 1-based rows
    integer(c_int), intent(in) :: cols(nnz)      !! 1-based columns
    real(c_double), intent(in) :: vals(nnz)      !! values
    real(c_double), intent(in) :: b(n)           !! right-hand side
    real(c_double), intent(out) :: x(n)          !! solution
    integer(c_int), intent(out) :: stat          !! status (3: singular)
    character(len=512), intent(out) :: errmsg    !! message
    type(csc_t) :: a
    type(lu_t) :: lu
    integer :: st
    errmsg = ''
    x = 0
    call csc_from_coo(n, rows, cols, vals, a, st, errmsg)
    if (st == STAT_OK) call lu_factor(lu, a, st, errmsg)
    if (st == STAT_OK) call lu_solve(lu, a, b, x, st, errmsg)
    call lu_free(lu)
    stat = st
end subroutine dc_umf_solve

!> Solve A x = b with linear_solver (CHOLMOD LDL^T when A is symmetric positive
!> definite, UMFPACK LU otherwise), A as 1-based COO triplets (duplicates summed);
!> backend = 'cholmod_ldlt' or 'umfpack_lu' (the one that solved), '' on failure.
subroutine dc_ls_solve(n, nnz, rows, cols, vals, b, x, backend, stat, errmsg)
    use iso_c_binding, only: c_int, c_double
    use errors, only: STAT_OK
    use sparse, only: csc_t, csc_from_coo
    use linear_solver, only: factor_t, ls_factor, ls_solve, ls_free
    implicit none
    integer(c_int), intent(in) :: n              !! size
    integer(c_int), intent(in) :: nnz            !! triplets
    integer(c_int), intent(in) :: rows(nnz)      !! 1-based rows
    integer(c_int), intent(in) :: cols(nnz)      !! 1-based columns
    real(c_double), intent(in) :: vals(nnz)      !! values
    real(c_double), intent(in) :: b(n)           !! right-hand side
    real(c_double), intent(out) :: x(n)          !! solution
    character(len=16), intent(out) :: backend    !! solver that ran
    integer(c_int), intent(out) :: stat          !! status (3: singular)
    character(len=512), intent(out) :: errmsg    !! message
    type(csc_t) :: a
    type(factor_t) :: f
    integer :: st
    errmsg = ''
    backend = ''
    x = 0
    call csc_from_coo(n, rows, cols, vals, a, st, errmsg)
    if (st == STAT_OK) call ls_factor(f, a, st, errmsg)
    if (st == STAT_OK) call ls_solve(f, a, b, x, st, errmsg)
    if (st == STAT_OK) backend = f%backend
    call ls_free(f)
    stat = st
end subroutine dc_ls_solve

!> Solve A X = B (m columns) with linear_solver configured to `kind` ('direct', 'cg',
!> 'auto' with dimension 2), A as 1-based COO triplets: one column through ls_solve,
!> several through ls_solve_many (one column may start CG from the guess x0). backend is the one that solved ('pcg' for CG),
!> note why CG did not run where asked, cg_its the CG iterations over all columns,
!> factorizations the factors' count (the direct factorization of a CG fallback included).
subroutine dc_ls_solve_kind(n, nnz, m, rows, cols, vals, b, kind, cg_rtol, cg_max_iter, x0, &
                            guess, x, backend, note, cg_its, factorizations, stat, errmsg)
    use iso_c_binding, only: c_int, c_double
    use kinds, only: i8
    use errors, only: STAT_OK
    use sparse, only: csc_t, csc_from_coo
    use linear_solver, only: factor_t, ls_factor, ls_solve, ls_solve_many, ls_free, &
                             ls_configure, ls_cg_counts
    implicit none
    integer(c_int), intent(in) :: n              !! size
    integer(c_int), intent(in) :: nnz            !! triplets
    integer(c_int), intent(in) :: m              !! right-hand sides
    integer(c_int), intent(in) :: rows(nnz)      !! 1-based rows
    integer(c_int), intent(in) :: cols(nnz)      !! 1-based columns
    real(c_double), intent(in) :: vals(nnz)      !! values
    real(c_double), intent(in) :: b(n, m)        !! right-hand sides
    character(len=*), intent(in) :: kind         !! 'direct', 'cg' or 'auto'
    real(c_double), intent(in) :: cg_rtol        !! CG relative residual tolerance
    integer(c_int), intent(in) :: cg_max_iter    !! CG iteration limit
    real(c_double), intent(in) :: x0(n)          !! CG's first guess (m = 1, guess /= 0)
    integer(c_int), intent(in) :: guess          !! 1: start CG from x0
    real(c_double), intent(out) :: x(n, m)       !! solutions
    character(len=16), intent(out) :: backend    !! solver that ran
    character(len=200), intent(out) :: note      !! why CG did not run ('' if it did)
    integer(c_int), intent(out) :: cg_its        !! CG iterations
    integer(c_int), intent(out) :: factorizations !! numeric factorizations done
    integer(c_int), intent(out) :: stat          !! status (3: singular, CG failure)
    character(len=512), intent(out) :: errmsg    !! message
    type(csc_t) :: a
    type(factor_t) :: f
    integer(i8) :: solves, its
    integer :: st, mx
    errmsg = ''
    backend = ''
    x = 0
    call csc_from_coo(n, rows, cols, vals, a, st, errmsg)
    call ls_configure(f, kind, 2, cg_rtol, cg_max_iter)
    if (st == STAT_OK) call ls_factor(f, a, st, errmsg)
    if (st == STAT_OK) then
        if (m == 1) then
            if (guess /= 0) x(:, 1) = x0
            call ls_solve(f, a, b(:, 1), x(:, 1), st, errmsg, guess=guess /= 0)
        else
            call ls_solve_many(f, a, b, x, st, errmsg)
        end if
    end if
    if (st == STAT_OK) backend = f%backend
    note = f%note
    call ls_cg_counts(f, solves, its, mx)
    cg_its = int(its, c_int)
    factorizations = int(f%factorizations, c_int)
    call ls_free(f)
    stat = st
end subroutine dc_ls_solve_kind

!> y = A x for the m columns of x, A symmetric as 1-based COO triplets, three ways: by the
!> node blocks CG finds in A's pattern one column at a time (pcg_product) and all columns
!> in one pass (pcg_product_many), and by columns of the CSC matrix (csc_matvec_t).
!> bs is the node block size found (1: the CSC product), ng the node groups.
subroutine dc_pcg_products(n, nnz, m, rows, cols, vals, x, y_block, y_many, y_csc, bs, ng, &
                           stat, errmsg)
    use iso_c_binding, only: c_int, c_double
    use errors, only: STAT_OK
    use sparse, only: csc_t, csc_from_coo, csc_matvec_t
    use pcg, only: pcg_t, pcg_setup, pcg_product, pcg_product_many, pcg_free
    implicit none
    integer(c_int), intent(in) :: n              !! size
    integer(c_int), intent(in) :: nnz            !! triplets
    integer(c_int), intent(in) :: m              !! vectors
    integer(c_int), intent(in) :: rows(nnz)      !! 1-based rows
    integer(c_int), intent(in) :: cols(nnz)      !! 1-based columns
    real(c_double), intent(in) :: vals(nnz)      !! values
    real(c_double), intent(in) :: x(n, m)        !! vectors
    real(c_double), intent(out) :: y_block(n, m) !! A x by blocks, column by column
    real(c_double), intent(out) :: y_many(n, m)  !! A x by blocks, all columns at once
    real(c_double), intent(out) :: y_csc(n, m)   !! A x by the CSC product
    integer(c_int), intent(out) :: bs            !! node block size found
    integer(c_int), intent(out) :: ng            !! node groups
    integer(c_int), intent(out) :: stat          !! status
    character(len=512), intent(out) :: errmsg    !! message
    type(csc_t) :: a
    type(pcg_t) :: p
    real(c_double), allocatable :: xt(:, :), yt(:, :)
    integer :: j, st
    errmsg = ''
    y_block = 0
    y_many = 0
    y_csc = 0
    bs = 0
    ng = 0
    call csc_from_coo(n, rows, cols, vals, a, st, errmsg)
    if (st == STAT_OK) call pcg_setup(p, a, 1.0e-12_c_double, 1, st, errmsg)
    if (st == STAT_OK) then
        bs = p%bs
        ng = p%ng
        do j = 1, m
            call pcg_product(p, a, x(:, j), y_block(:, j))
            call csc_matvec_t(a, x(:, j), y_csc(:, j))
        end do
        xt = transpose(x)
        allocate (yt(m, n))
        call pcg_product_many(p, a, m, xt, yt)
        y_many = transpose(yt)
    end if
    call pcg_free(p)
    stat = st
end subroutine dc_pcg_products

!> The solver kind that runs for a requested kind ('direct', 'cg', 'auto'), a mesh of
!> dimension dim, a matrix of matrix_nnz entries whose LDL^T factor has factor_nnz (the
!> symbolic analysis'), and the constants of 'auto''s cost model.
subroutine dc_ls_auto_kind(kind, dim, matrix_nnz, factor_nnz, threads, resolved, auto_its, &
                           margin, speedup)
    use iso_c_binding, only: c_int, c_int64_t, c_double
    use kinds, only: i8
    use linear_solver, only: ls_auto_kind, AUTO_CG_ITS, AUTO_CG_MARGIN, AUTO_PAR_SPEEDUP
    implicit none
    character(len=*), intent(in) :: kind            !! requested kind
    integer(c_int), intent(in) :: dim               !! mesh dimension
    integer(c_int64_t), intent(in) :: matrix_nnz  !! entries of the matrix
    integer(c_int64_t), intent(in) :: factor_nnz  !! entries of its factor (D and L)
    integer(c_int), intent(in) :: threads           !! threads of the direct solve (1, 2)
    character(len=8), intent(out) :: resolved       !! 'direct' or 'cg'
    integer(c_int), intent(out) :: auto_its(3)      !! AUTO_CG_ITS by dimension
    real(c_double), intent(out) :: margin(3)        !! AUTO_CG_MARGIN by dimension
    real(c_double), intent(out) :: speedup          !! AUTO_PAR_SPEEDUP
    resolved = ls_auto_kind(kind, dim, int(matrix_nnz, i8), int(factor_nnz, i8), threads)
    auto_its = AUTO_CG_ITS
    margin = AUTO_CG_MARGIN
    speedup = AUTO_PAR_SPEEDUP
end subroutine dc_ls_auto_kind

!> 'auto' on a matrix given as 1-based COO triplets and a mesh dimension: the kind it
!> chose, the backend that factorized, the inputs of the decision (nnz of the matrix and
!> the analysis' factor entries, 0 without an analysis), its reason, and the entries of
!> the factor a 'direct' factorization of the same matrix stores (D and L, 0 if not
!> LDL^T).
subroutine dc_ls_auto_decide(n, nnz, rows, cols, vals, dim, resolved, backend, matrix_nnz, &
                             analysis_nnz, direct_nnz, reason, stat, errmsg)
    use iso_c_binding, only: c_int, c_int64_t, c_double
    use kinds, only: i8, dp
    use errors, only: STAT_OK
    use sparse, only: csc_t, csc_from_coo
    use linear_solver, only: factor_t, ls_factor, ls_free, ls_configure, ls_factor_info, &
                             ls_auto_reason
    implicit none
    integer(c_int), intent(in) :: n                     !! size
    integer(c_int), intent(in) :: nnz                   !! triplets
    integer(c_int), intent(in) :: rows(nnz)             !! 1-based rows
    integer(c_int), intent(in) :: cols(nnz)             !! 1-based columns
    real(c_double), intent(in) :: vals(nnz)             !! values
    integer(c_int), intent(in) :: dim                   !! mesh dimension
    character(len=8), intent(out) :: resolved           !! 'direct' or 'cg'
    character(len=16), intent(out) :: backend           !! backend of the 'auto' factor_t
    integer(c_int64_t), intent(out) :: matrix_nnz     !! the decision's nnz(A)
    integer(c_int64_t), intent(out) :: analysis_nnz   !! the decision's factor entries
    integer(c_int64_t), intent(out) :: direct_nnz     !! a direct factorization's entries
    character(len=160), intent(out) :: reason           !! ls_auto_reason
    integer(c_int), intent(out) :: stat                 !! status
    character(len=512), intent(out) :: errmsg           !! message
    type(csc_t) :: a
    type(factor_t) :: f, g
    character(len=:), allocatable :: ordering
    integer(i8) :: fnnz
    integer :: st
    errmsg = ''
    resolved = ''
    backend = ''
    reason = ''
    matrix_nnz = 0
    analysis_nnz = 0
    direct_nnz = 0
    call csc_from_coo(n, rows, cols, vals, a, st, errmsg)
    call ls_configure(f, 'auto', dim, 1.0e-12_dp, 500)
    if (st == STAT_OK) call ls_factor(f, a, st, errmsg)
    if (st == STAT_OK) then
        resolved = f%auto_kind
        backend = f%backend
        matrix_nnz = f%auto_nnz
        analysis_nnz = f%auto_factor_nnz
        reason = ls_auto_reason(f)
        call ls_configure(g, 'direct', dim, 1.0e-12_dp, 500)
        call ls_factor(g, a, st, errmsg)
    end if
    if (st == STAT_OK) then
        call ls_factor_info(g, ordering, fnnz)
        direct_nnz = fnnz
    end if
    call ls_free(f)
    call ls_free(g)
    stat = st
end subroutine dc_ls_auto_decide

!> The pc family's stability limit Omega_c of omega dt (explicit_schemes.f90) and its
!> amplification matrix at omega_dt, for the recurrence's (alpha, beta, gamma).
subroutine dc_pc_stability(alpha, beta, gamma, omega_dt, omega_c, amp)
    use iso_c_binding, only: c_double
    use explicit_schemes, only: pc_stability_limit, pc_amplification
    implicit none
    real(c_double), intent(in) :: alpha            !! HHT alpha (0 for pc)
    real(c_double), intent(in) :: beta, gamma      !! corrector beta, gamma
    real(c_double), intent(in) :: omega_dt         !! where amp is wanted
    real(c_double), intent(out) :: omega_c         !! stability limit of omega dt
    real(c_double), intent(out) :: amp(3, 3)       !! amplification matrix on (u, dt v, dt^2 a)
    omega_c = pc_stability_limit(alpha, beta, gamma)
    amp = pc_amplification(alpha, beta, gamma, omega_dt)
end subroutine dc_pc_stability

!> P1 element matrices of one cell: stiffness, consistent and lumped mass.
!> The leading n x n blocks (n = dim (dim + 1)) and x(1:dim, 1:dim + 1) are used.
subroutine dc_p1_element(dim, x, young, poisson, density, ke, me, ml)
    use iso_c_binding, only: c_int, c_double
    use fe_p1, only: p1_stiffness, p1_mass, p1_lame
    implicit none
    integer(c_int), intent(in) :: dim            !! 1, 2 or 3
    real(c_double), intent(in) :: x(3, 4)        !! node coordinates
    real(c_double), intent(in) :: young          !! E
    real(c_double), intent(in) :: poisson        !! nu
    real(c_double), intent(in) :: density        !! rho
    real(c_double), intent(out) :: ke(12, 12)    !! stiffness
    real(c_double), intent(out) :: me(12, 12)    !! consistent mass
    real(c_double), intent(out) :: ml(12, 12)    !! lumped mass
    real(c_double) :: lambda, mu
    integer :: n
    ke = 0; me = 0; ml = 0
    n = dim * (dim + 1)
    call p1_lame(young, poisson, lambda, mu)
    call p1_stiffness(dim, x(1:dim, 1:dim + 1), lambda, mu, young, ke(1:n, 1:n))
    call p1_mass(dim, x(1:dim, 1:dim + 1), density, .false., me(1:n, 1:n))
    call p1_mass(dim, x(1:dim, 1:dim + 1), density, .true., ml(1:n, 1:n))
end subroutine dc_p1_element

!> Load a mesh: a mesh file (path /= '') or the built-in bar (dim, length, width, h), and
!> its sizes. The mesh is kept behind `handle` (0 on error) for dc_mesh_arrays, which
!> copies and releases it, or dc_mesh_free. checked = 0: a file's mesh is read without
!> mesh_check (reader-level use, 3D meshes). given: the bits (1 h, 2 length, 4 width;
!> gmsh_mesh's GEO_GIVEN_*) of the .geo parameters the scene gives, set as the file's; one
!> not given keeps the file's own value where it defines it (DefineConstant), and h not
!> given leaves a .geo that uses no h its own mesh sizes (otherwise h is its largest).
!> max_elements > 0: a .geo whose element count, estimated before meshing, is too large
!> for it is refused without meshing (stat 2, naming &mesh max_elements).
subroutine dc_mesh_sizes(path, bar_dim, length, width, h, checked, given, max_elements, &
                         handle, dim, n_nodes, n_cells, n_facets, n_groups, stat, errmsg)
    use iso_c_binding, only: c_int, c_int64_t, c_double, c_loc
    use mesh, only: mesh_t
    use mesh_source, only: mesh_load
    implicit none
    character(len=*), intent(in) :: path         !! .msh/.geo file, '' = built-in bar
    integer(c_int), intent(in) :: bar_dim        !! built-in bar dimension
    real(c_double), intent(in) :: length         !! built-in bar length
    real(c_double), intent(in) :: width          !! built-in bar width
    real(c_double), intent(in) :: h              !! built-in bar mesh size
    integer(c_int), intent(in) :: checked        !! 0: no mesh_check of a file's mesh
    integer(c_int), intent(in) :: given          !! a .geo's given parameters (bits; 7: all)
    integer(c_int), intent(in) :: max_elements   !! > 0: refuse a .geo estimated larger
    integer(c_int64_t), intent(out) :: handle    !! the loaded mesh (0 on error)
    integer(c_int), intent(out) :: dim           !! mesh dimension
    integer(c_int), intent(out) :: n_nodes       !! nodes
    integer(c_int), intent(out) :: n_cells       !! cells
    integer(c_int), intent(out) :: n_facets      !! tagged facets
    integer(c_int), intent(out) :: n_groups      !! physical groups
    integer(c_int), intent(out) :: stat          !! status
    character(len=512), intent(out) :: errmsg    !! message
    type(mesh_t), pointer :: msh
    integer :: st
    errmsg = ''
    handle = 0
    allocate (msh)
    call mesh_load(path, bar_dim, length, width, h, msh, st, errmsg, checked /= 0, int(given), &
                   int(max_elements))
    stat = st
    dim = msh%dim; n_nodes = msh%n_nodes; n_cells = msh%n_cells
    n_facets = msh%n_facets; n_groups = msh%n_groups
    if (st /= 0) then
        deallocate (msh)
        return
    end if
    handle = transfer(c_loc(msh), handle)
end subroutine dc_mesh_sizes

!> The element count of the .geo `path` estimated before meshing, as dc_mesh_sizes would
!> mesh it (nothing is meshed): est = (estimate, measure, size, margin of the refusal),
!> estimate -1 where none can be made (docs/scenes.md, "How large a .geo will be"). With
!> limit > 0, `text` is the core's one-line refusal when the estimate exceeds margin x
!> limit, the file named, with `limit_key` and `h_key` ('' when h is not given) as the keys
!> that change it; '' otherwise.
subroutine dc_geo_estimate(path, length, width, h, given, limit, limit_key, h_key, est, &
                           text, stat, errmsg)
    use iso_c_binding, only: c_int, c_double
    use errors, only: STAT_OK
    use gmsh_mesh, only: estimate_geo_cells, too_large_text
    implicit none
    character(len=*), intent(in) :: path         !! .geo file
    real(c_double), intent(in) :: length         !! parameter length
    real(c_double), intent(in) :: width          !! parameter width
    real(c_double), intent(in) :: h              !! parameter h
    integer(c_int), intent(in) :: given          !! given parameters (bits, dc_mesh_sizes)
    integer(c_int), intent(in) :: limit          !! the element limit (0: no refusal text)
    character(len=*), intent(in) :: limit_key    !! the limit's key, as the caller names it
    character(len=*), intent(in) :: h_key        !! h's key, '' when h is not given
    real(c_double), intent(out) :: est(4)        !! estimate, measure, size, margin
    character(len=512), intent(out) :: text      !! the refusal, '' if none
    integer(c_int), intent(out) :: stat          !! status
    character(len=512), intent(out) :: errmsg    !! message
    integer :: st
    errmsg = ''
    text = ''
    call estimate_geo_cells(path, h, length, width, int(given), est, st, errmsg)
    stat = st
    if (st /= STAT_OK .or. limit <= 0 .or. est(1) < 0) return
    if (est(1) > est(4) * limit) text = path//': '//too_large_text(est, int(limit), limit_key, &
                                                                   h_key)
end subroutine dc_geo_estimate

!> Refuse a .geo with one of gmsh's commands that end, stall or escape the process, in it
!> or in a file it includes or merges (stat STAT_BAD_INPUT, errmsg naming the file and the
!> command): the scan of the core's reader and estimate, without gmsh.
subroutine dc_geo_check(path, stat, errmsg)
    use iso_c_binding, only: c_int
    use gmsh_mesh, only: geo_check_commands
    implicit none
    character(len=*), intent(in) :: path         !! .geo file
    integer(c_int), intent(out) :: stat          !! status
    character(len=512), intent(out) :: errmsg    !! message
    integer :: st
    errmsg = ''
    call geo_check_commands(path, st, errmsg)
    stat = st
end subroutine dc_geo_check

!> Why a .geo meshed in-process is refused when gmsh left entity `d` `tag` of physical
!> group `group` without elements (the reader's wording, without the path in front).
subroutine dc_unmeshed_text(d, tag, group, text)
    use iso_c_binding, only: c_int
    use gmsh_mesh, only: unmeshed_text
    implicit none
    integer(c_int), intent(in) :: d              !! the entity's dimension (1 curve ... 3 volume)
    integer(c_int), intent(in) :: tag            !! its gmsh tag
    character(len=*), intent(in) :: group        !! its physical group's name
    character(len=512), intent(out) :: text      !! the refusal
    text = unmeshed_text(int(d), int(tag), group, 0)
end subroutine dc_unmeshed_text

!> Release a mesh of dc_mesh_sizes without copying it (0 is ignored).
subroutine dc_mesh_free(handle)
    use iso_c_binding, only: c_int64_t
    use mesh, only: mesh_t
    use api_handles, only: mesh_from_handle
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! from dc_mesh_sizes
    type(mesh_t), pointer :: msh
    if (handle == 0) return
    call mesh_from_handle(handle, msh)
    deallocate (msh)
end subroutine dc_mesh_free

!> The number of (group, node) pairs of the groups of a lower dimension (Physical Points;
!> Curves of a 3D mesh) of the mesh of dc_mesh_sizes, for dc_mesh_lower_arrays.
subroutine dc_mesh_lower_size(handle, n_lower)
    use iso_c_binding, only: c_int, c_int64_t
    use mesh, only: mesh_t
    use api_handles, only: mesh_from_handle
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! from dc_mesh_sizes
    integer(c_int), intent(out) :: n_lower       !! pairs (0 for handle 0)
    type(mesh_t), pointer :: msh
    n_lower = 0
    if (handle == 0) return
    call mesh_from_handle(handle, msh)
    n_lower = msh%n_lower
end subroutine dc_mesh_lower_size

!> Those pairs of the mesh of dc_mesh_sizes (kept: dc_mesh_arrays releases it): node
!> numbers and group indices, 1-based, sorted by group then node.
subroutine dc_mesh_lower_arrays(handle, n_lower, lower_nodes, lower_group, stat, errmsg)
    use iso_c_binding, only: c_int, c_int64_t
    use mesh, only: mesh_t
    use api_handles, only: mesh_from_handle
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! from dc_mesh_sizes
    integer(c_int), intent(in) :: n_lower        !! pairs (dc_mesh_lower_size)
    integer(c_int), intent(out) :: lower_nodes(n_lower)   !! node of each pair
    integer(c_int), intent(out) :: lower_group(n_lower)   !! group of each pair
    integer(c_int), intent(out) :: stat          !! status
    character(len=512), intent(out) :: errmsg    !! message
    type(mesh_t), pointer :: msh
    errmsg = ''
    stat = 0
    lower_nodes = 0; lower_group = 0
    if (handle == 0) then
        stat = 4
        errmsg = 'dc_mesh_lower_arrays: no mesh (handle 0)'
        return
    end if
    call mesh_from_handle(handle, msh)
    if (msh%n_lower /= n_lower) then
        stat = 4
        errmsg = 'dc_mesh_lower_arrays: size differs from the mesh'
    else if (n_lower > 0) then
        lower_nodes = msh%lower_nodes; lower_group = msh%lower_group
    end if
end subroutine dc_mesh_lower_arrays

!> Arrays of the mesh of dc_mesh_sizes (its sizes), which is then released. Group names
!> are joined by ','.
subroutine dc_mesh_arrays(handle, dim, n_nodes, n_cells, n_facets, n_groups, x, cells, &
                          cell_group, facets, facet_group, group_dim, group_names, stat, errmsg)
    use iso_c_binding, only: c_int, c_int64_t, c_double
    use mesh, only: mesh_t
    use api_handles, only: mesh_from_handle
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! from dc_mesh_sizes
    integer(c_int), intent(in) :: dim            !! mesh dimension
    integer(c_int), intent(in) :: n_nodes        !! nodes
    integer(c_int), intent(in) :: n_cells        !! cells
    integer(c_int), intent(in) :: n_facets       !! tagged facets
    integer(c_int), intent(in) :: n_groups       !! groups
    real(c_double), intent(out) :: x(dim, n_nodes)          !! coordinates
    integer(c_int), intent(out) :: cells(dim + 1, n_cells)  !! cell nodes (1-based)
    integer(c_int), intent(out) :: cell_group(n_cells)      !! cell group (1-based, 0 none)
    integer(c_int), intent(out) :: facets(dim, n_facets)    !! facet nodes (1-based)
    integer(c_int), intent(out) :: facet_group(n_facets)    !! facet group (1-based)
    integer(c_int), intent(out) :: group_dim(n_groups)      !! group dimension
    character(len=4096), intent(out) :: group_names         !! names joined by ','
    integer(c_int), intent(out) :: stat          !! status
    character(len=512), intent(out) :: errmsg    !! message
    type(mesh_t), pointer :: msh
    integer :: g
    errmsg = ''
    group_names = ''
    x = 0; cells = 0; cell_group = 0; facets = 0; facet_group = 0; group_dim = 0
    stat = 0
    if (handle == 0) then
        stat = 4
        errmsg = 'dc_mesh_arrays: no mesh (handle 0)'
        return
    end if
    call mesh_from_handle(handle, msh)
    if (msh%dim /= dim .or. msh%n_nodes /= n_nodes .or. msh%n_cells /= n_cells .or. &
        msh%n_facets /= n_facets .or. msh%n_groups /= n_groups) then
        stat = 4
        errmsg = 'dc_mesh_arrays: sizes differ from the mesh'
    else
        x = msh%x; cells = msh%cells; cell_group = msh%cell_group
        facets = msh%facets; facet_group = msh%facet_group; group_dim = msh%group_dim
        do g = 1, n_groups
            if (g > 1) group_names = trim(group_names)//','
            group_names = trim(group_names)//trim(msh%group_name(g))
        end do
    end if
    deallocate (msh)
end subroutine dc_mesh_arrays

!> Cost floors of an open run's step (us): triangular solve with the cached factors
!> of the iteration matrix (implicit), SpMV with K_theta, M^{-1} application (pc), and
!> the iteration matrix's solve through cholmod_solve2 on the same factor (comparison).
subroutine dc_bench_floor(handle, n_rep, t_solve_us, t_spmv_us, t_mass_us, t_cholmod_us)
    use iso_c_binding, only: c_int, c_int64_t, c_double
    use simulation, only: simulation_t
    use api_handles, only: sim_from_handle, sim_bench_floor
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! run handle (opened with outputs)
    integer(c_int), intent(in) :: n_rep          !! repetitions
    real(c_double), intent(out) :: t_solve_us    !! us per triangular solve (0 if none)
    real(c_double), intent(out) :: t_spmv_us     !! us per SpMV
    real(c_double), intent(out) :: t_mass_us     !! us per M^{-1} application (0 if none)
    real(c_double), intent(out) :: t_cholmod_us  !! us per cholmod_solve2 of the same system (0 if n/a)
    type(simulation_t), pointer :: sim
    real(c_double) :: a, b, c, d
    call sim_from_handle(handle, sim)
    call sim_bench_floor(sim, max(1, int(n_rep)), a, b, c, d)
    t_solve_us = a; t_spmv_us = b; t_mass_us = c; t_cholmod_us = d
end subroutine dc_bench_floor

!> The state of an open run (after dc_sim_open with outputs, and each dc_sim_advance):
!> time, displacement, velocity, acceleration (0 for the theta scheme, which has none),
!> the product M v the run's energies use, the load L and B(u) as carried, on the free
!> dofs; whether the last step found contact impossible at u, and the total normal
!> contact force f_n at u (the value the trace writes for this step).
subroutine dc_sim_state(handle, n, t, u, v, a, mv, load, bu, clear, f_n)
    use iso_c_binding, only: c_int, c_int64_t, c_double
    use simulation, only: simulation_t
    use api_handles, only: sim_from_handle
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! run handle
    integer(c_int), intent(in) :: n              !! free dofs
    real(c_double), intent(out) :: t             !! time
    real(c_double), intent(out) :: u(n)          !! displacement
    real(c_double), intent(out) :: v(n)          !! velocity
    real(c_double), intent(out) :: a(n)          !! acceleration
    real(c_double), intent(out) :: mv(n)         !! M v as used for e_kin
    real(c_double), intent(out) :: load(n)       !! L
    real(c_double), intent(out) :: bu(n)         !! B(u) as the scheme carries it
    integer(c_int), intent(out) :: clear         !! 1: the last step found no contact point
                                                 !! possible at u (state_t's clear), else 0
    real(c_double), intent(out) :: f_n           !! total normal contact force at u (the
                                                 !! trace's f_n, state_t's f_n)
    type(simulation_t), pointer :: sim
    call sim_from_handle(handle, sim)
    clear = merge(1, 0, sim%st%clear)
    f_n = sim%st%f_n
    t = sim%st%t
    u = sim%st%u
    v = sim%st%v
    a = sim%st%a
    mv = sim%st%mv
    load = sim%mdl%load
    bu = sim%st%bu
end subroutine dc_sim_state

!> The time an open run has reached (dc_sim_state's t), without copying its state.
subroutine dc_sim_time(handle, t)
    use iso_c_binding, only: c_int64_t, c_double
    use simulation, only: simulation_t
    use api_handles, only: sim_from_handle
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! run handle
    real(c_double), intent(out) :: t             !! time
    type(simulation_t), pointer :: sim
    call sim_from_handle(handle, sim)
    t = sim%st%t
end subroutine dc_sim_time

!> Stored entries of the assembled matrices of an open run (M, K, K_theta share a pattern).
subroutine dc_sim_matrix_nnz(handle, nnz)
    use iso_c_binding, only: c_int, c_int64_t
    use simulation, only: simulation_t
    use api_handles, only: sim_from_handle
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! run handle
    integer(c_int), intent(out) :: nnz           !! stored entries
    type(simulation_t), pointer :: sim
    call sim_from_handle(handle, sim)
    nnz = sim%mdl%stiff%nnz
end subroutine dc_sim_matrix_nnz

!> One assembled matrix of an open run on the free dofs, as 0-based CSC:
!> which = 1: M (consistent or lumped, as the scene says), 2: K, 3: K_theta.
subroutine dc_sim_matrix(handle, which, n, nnz, colptr, rowind, val, stat, errmsg)
    use iso_c_binding, only: c_int, c_int64_t, c_double
    use errors, only: STAT_OK, STAT_BAD_INPUT
    use simulation, only: simulation_t
    use api_handles, only: sim_from_handle
    use model, only: model_stiff_theta_values
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! run handle
    integer(c_int), intent(in) :: which          !! 1 M, 2 K, 3 K_theta
    integer(c_int), intent(in) :: n              !! free dofs
    integer(c_int), intent(in) :: nnz            !! from dc_sim_matrix_nnz
    integer(c_int), intent(out) :: colptr(n + 1) !! 0-based column starts
    integer(c_int), intent(out) :: rowind(nnz)   !! 0-based row indices
    real(c_double), intent(out) :: val(nnz)      !! values
    integer(c_int), intent(out) :: stat          !! status
    character(len=512), intent(out) :: errmsg    !! message
    type(simulation_t), pointer :: sim
    errmsg = ''
    colptr = 0; rowind = 0; val = 0.0_c_double
    call sim_from_handle(handle, sim)
    if (n /= sim%mdl%n_dofs .or. nnz /= sim%mdl%stiff%nnz) then
        stat = STAT_BAD_INPUT
        errmsg = 'dc_sim_matrix: n or nnz do not match the model'
        return
    end if
    stat = STAT_OK
    colptr = sim%mdl%stiff%colptr    ! the pattern of M, K and K_theta
    rowind = sim%mdl%stiff%rowind
    select case (which)
    case (1)
        val = sim%mdl%mass_val
    case (2)
        val = sim%mdl%stiff%val
    case (3)
        call model_stiff_theta_values(sim%mdl, val)
    case default
        stat = STAT_BAD_INPUT
        errmsg = 'dc_sim_matrix: which must be 1 (M), 2 (K) or 3 (K_theta)'
    end select
end subroutine dc_sim_matrix

!> Facts about an open run: the 64-bit step count, the expected trace size and the
!> model's warnings and notes (lines separated by new_line, to print before the run).
subroutine dc_sim_info(handle, n_steps, trace_bytes, notes)
    use iso_c_binding, only: c_int64_t
    use simulation, only: simulation_t, sim_trace_bytes
    use api_handles, only: sim_from_handle
    implicit none
    integer(c_int64_t), intent(in) :: handle       !! run handle
    integer(c_int64_t), intent(out) :: n_steps     !! steps to t_end
    integer(c_int64_t), intent(out) :: trace_bytes !! expected size of trace.csv
    character(len=4096), intent(out) :: notes      !! warnings and notes
    type(simulation_t), pointer :: sim
    call sim_from_handle(handle, sim)
    n_steps = sim%n_steps
    trace_bytes = sim_trace_bytes(sim)
    notes = sim%mdl%notes
end subroutine dc_sim_info

!> Open a run that continues from the checkpoint in restart_dir (its output folder):
!> as dc_sim_open with outputs, and the step it restarts at.
subroutine dc_sim_open_restart(path, restart_dir, handle, n_steps, step, stat, errmsg)
    use iso_c_binding, only: c_int, c_int64_t
    use errors, only: STAT_OK
    use simulation, only: simulation_t
    use api_handles, only: sim_open_handle
    implicit none
    character(len=*), intent(in) :: path         !! scene file
    character(len=*), intent(in) :: restart_dir  !! folder holding checkpoint.bin
    integer(c_int64_t), intent(out) :: handle    !! opaque run handle (0 on error)
    integer(c_int64_t), intent(out) :: n_steps   !! steps to t_end
    integer(c_int64_t), intent(out) :: step      !! the step the run continues from
    integer(c_int), intent(out) :: stat          !! status (2: no, foreign or corrupt checkpoint)
    character(len=512), intent(out) :: errmsg    !! message
    type(simulation_t), pointer :: sim
    integer :: st
    errmsg = ''
    n_steps = 0; step = 0
    call sim_open_handle(path, '', .true., handle, sim, st, errmsg, restart=restart_dir)
    stat = st
    if (st /= STAT_OK) return
    n_steps = sim%n_steps
    step = sim%step
end subroutine dc_sim_open_restart

!> Save the state of an open run (and its counters) to a checkpoint file (the trace
!> rows so far written and synced first, as the run's own checkpoints do).
subroutine dc_sim_save(handle, path, stat, errmsg)
    use iso_c_binding, only: c_int, c_int64_t
    use simulation, only: simulation_t, sim_save
    use api_handles, only: sim_from_handle
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! run handle
    character(len=*), intent(in) :: path         !! checkpoint file to write
    integer(c_int), intent(out) :: stat          !! status
    character(len=512), intent(out) :: errmsg    !! message
    type(simulation_t), pointer :: sim
    integer :: st
    errmsg = ''
    call sim_from_handle(handle, sim)
    call sim_save(sim, path, st, errmsg)
    stat = st
end subroutine dc_sim_save

!> Load a state saved by dc_sim_save (or a run's checkpoint) of the same scene into an
!> open run; its trace is cut back to the rows up to that step, as --restart does
!> (simulation's sim_load), and continues from there. step: the step loaded.
subroutine dc_sim_load(handle, path, step, stat, errmsg)
    use iso_c_binding, only: c_int, c_int64_t
    use simulation, only: simulation_t, sim_load
    use api_handles, only: sim_from_handle
    implicit none
    integer(c_int64_t), intent(in) :: handle     !! run handle
    character(len=*), intent(in) :: path         !! checkpoint file
    integer(c_int64_t), intent(out) :: step      !! the step of the loaded state
    integer(c_int), intent(out) :: stat          !! status (2: foreign or corrupt checkpoint)
    character(len=512), intent(out) :: errmsg    !! message
    type(simulation_t), pointer :: sim
    integer :: st
    errmsg = ''
    call sim_from_handle(handle, sim)
    call sim_load(sim, path, st, errmsg)
    step = sim%step
    stat = st
end subroutine dc_sim_load

!> The 2x2 (3x3) block solves of A (symmetric positive definite, 1-based COO triplets,
!> made of node pairs or triples) on one thread and on two (ldl_solves' split of the
!> elimination tree, at any size, whatever the setting and the environment) for the m
!> columns of b, to compare the two. split = [block columns, last column of the first
!> range (0: no split, serial), first column of the separator]; kernel = chol_kernel's
!> name.
subroutine dc_ldl_threads_compare(n, nnz, m, rows, cols, vals, b, x_serial, x_threads, split, &
                                  kernel, stat, errmsg)
    use iso_c_binding, only: c_int, c_double
    use errors, only: STAT_OK
    use sparse, only: csc_t, csc_from_coo
    use cholmod, only: cholmod_t, chol_factor, chol_solve, chol_kernel, chol_free
    use ldl_solves, only: ldl_threads_set
    implicit none
    integer(c_int), intent(in) :: n              !! size
    integer(c_int), intent(in) :: nnz            !! triplets
    integer(c_int), intent(in) :: m              !! right-hand sides
    integer(c_int), intent(in) :: rows(nnz)      !! 1-based rows
    integer(c_int), intent(in) :: cols(nnz)      !! 1-based columns
    real(c_double), intent(in) :: vals(nnz)      !! values
    real(c_double), intent(in) :: b(n, m)        !! right-hand sides
    real(c_double), intent(out) :: x_serial(n, m)   !! solutions on one thread
    real(c_double), intent(out) :: x_threads(n, m)  !! solutions on two threads
    integer(c_int), intent(out) :: split(3)      !! block columns, end of the first range, separator
    character(len=16), intent(out) :: kernel     !! triangular solve used
    integer(c_int), intent(out) :: stat          !! status
    character(len=512), intent(out) :: errmsg    !! message
    type(csc_t) :: a
    type(cholmod_t) :: ch
    integer :: st, j
    errmsg = ''
    kernel = ''
    x_serial = 0
    x_threads = 0
    split = 0
    call csc_from_coo(n, rows, cols, vals, a, st, errmsg)
    if (st == STAT_OK) call chol_factor(ch, a, st, errmsg)
    if (st == STAT_OK) then
        kernel = chol_kernel(ch)
        call ldl_threads_set(ch%pairs, 1, huge(1))
        call ldl_threads_set(ch%triples, 1, huge(1))
        do j = 1, m
            if (st == STAT_OK) call chol_solve(ch, b(:, j), x_serial(:, j), st, errmsg)
        end do
        call ldl_threads_set(ch%pairs, 2, 0)
        call ldl_threads_set(ch%triples, 2, 0)
        do j = 1, m
            if (st == STAT_OK) call chol_solve(ch, b(:, j), x_threads(:, j), st, errmsg)
        end do
        split = [ch%pairs%nn, ch%pairs%sa, ch%pairs%ss]
        if (ch%triples%n > 0) split = [ch%triples%nt, ch%triples%sa, ch%triples%ss]
    end if
    call chol_free(ch)
    stat = st
end subroutine dc_ldl_threads_compare

!> The threads of the triangular solves the core chooses (ldl_solves' ldl_threads_choice)
!> for the setting `asked` (&solver threads: 0 automatic, 1, 2), DYNCONTACT_THREADS `env`
!> (0: not set, 1, 2), `cpus` CPUs the process may use and a factor of n dofs; and the
!> values this process sees: its CPUs (ldl_cpus) and the size from which two threads
!> are used (PAR_MIN_DOFS).
subroutine dc_threads_choice(asked, env, cpus, n, threads, cpus_here, min_dofs)
    use iso_c_binding, only: c_int
    use ldl_solves, only: ldl_threads_choice, ldl_cpus, PAR_MIN_DOFS
    implicit none
    integer(c_int), intent(in) :: asked          !! 0, 1 or 2
    integer(c_int), intent(in) :: env            !! 0, 1 or 2
    integer(c_int), intent(in) :: cpus           !! CPUs the process may use
    integer(c_int), intent(in) :: n              !! dofs of the factor
    integer(c_int), intent(out) :: threads       !! 1 or 2
    integer(c_int), intent(out) :: cpus_here     !! ldl_cpus() in this process
    integer(c_int), intent(out) :: min_dofs      !! PAR_MIN_DOFS
    threads = ldl_threads_choice(asked, env, cpus, n, PAR_MIN_DOFS)
    cpus_here = ldl_cpus()
    min_dofs = PAR_MIN_DOFS
end subroutine dc_threads_choice

!> Flat API (f2py, with api.f90): what an open run prints before its steps.

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

!> The lines a run prints on stdout before its steps, shared by the executable (main.f90)
!> and the Python CLI (through the flat API), so that a job's log reads the same from
!> either entry point.
module run_lines
    use kinds, only: i8
    use simulation, only: simulation_t
    use text, only: int_text, real_text, counted
    implicit none
    private
    public :: start_line, restart_line

contains

    !> 'SCENE: N dofs, M elements, F contact facets; SCHEME, K steps -> DIR', without the
    !> program's prefix: the run as opened, the scene and the output folder as given.
    function start_line(sim, scene_said, out_said) result(s)
        type(simulation_t), intent(in) :: sim      !! the opened run
        character(len=*), intent(in) :: scene_said !! the scene file as given
        character(len=*), intent(in) :: out_said   !! the output folder as given
        character(len=:), allocatable :: s
        s = scene_said//': '//counted(int(sim%n_dofs, i8), 'dof')//', '// &
            counted(int(sim%n_cells, i8), 'element')//', '// &
            counted(int(sim%n_contact, i8), 'contact facet')//'; '// &
            trim(sim%scn%scheme_name)//', '//counted(sim%n_steps, 'step')//' -> '//out_said
    end function start_line

    !> 'restart at step N, t=T' for a run opened on a checkpoint; '' for any other run.
    function restart_line(sim) result(s)
        type(simulation_t), intent(in) :: sim      !! the opened run
        character(len=:), allocatable :: s
        s = ''
        if (sim%restart_step >= 0) s = 'restart at step '//int_text(sim%restart_step)// &
            ', t='//real_text(sim%st%t, 6)
    end function restart_line
end module run_lines

!> Helpers of the flat API: handle <-> simulation pointer, mesh loading.
module api_handles
    use iso_c_binding, only: c_int64_t, c_ptr, c_f_pointer
    use kinds, only: dp
    use mesh, only: mesh_t
    use gmsh_reader, only: read_gmsh
    use bar_mesh, only: bar_mesh_build
    use simulation, only: simulation_t
    implicit none
    private
    public :: sim_from_handle, load_mesh

contains

    !> The simulation behind an opaque handle made by dc_sim_open.
    subroutine sim_from_handle(handle, sim)
        integer(c_int64_t), intent(in) :: handle          !! handle
        type(simulation_t), pointer, intent(out) :: sim   !! the run
        type(c_ptr) :: p
        p = transfer(handle, p)
        call c_f_pointer(p, sim)
    end subroutine sim_from_handle

    !> A .msh file (path /= '') or the built-in bar.
    subroutine load_mesh(path, bar_dim, length, width, h, msh, stat, errmsg)
        character(len=*), intent(in) :: path                !! .msh file or ''
        integer, intent(in) :: bar_dim                      !! bar dimension
        real(dp), intent(in) :: length                      !! bar length
        real(dp), intent(in) :: width                       !! bar width
        real(dp), intent(in) :: h                           !! bar mesh size
        type(mesh_t), intent(out) :: msh                    !! mesh
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        if (len_trim(path) > 0) then
            call read_gmsh(path, msh, stat, errmsg)
        else
            call bar_mesh_build(bar_dim, length, width, h, msh, stat, errmsg)
        end if
    end subroutine load_mesh
end module api_handles

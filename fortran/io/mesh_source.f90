!> The one place a mesh is loaded: a mesh file (read through gmsh) or the built-in bar (used by the run
!> and by the flat API).
module mesh_source
    use kinds, only: dp
    use mesh, only: mesh_t
    use gmsh_mesh, only: read_mesh_file
    use bar_mesh, only: bar_mesh_build
    implicit none
    private
    public :: mesh_load, mesh_label

contains

    !> A mesh file (path /= '': .msh, or .geo meshed with the parameters h, length, width)
    !> or the built-in bar (bar_dim, length, width, h). check = .false.: a file's mesh is
    !> not checked (mesh_check), for reading meshes the model does not take yet.
    !> given: the .geo parameters the scene gives (GEO_GIVEN_* bits of gmsh_mesh, default
    !> all; read_mesh_file). max_elements > 0: a .geo estimated above it is refused before
    !> meshing (read_mesh_file).
    subroutine mesh_load(path, bar_dim, length, width, h, msh, stat, errmsg, check, given, &
                         max_elements)
        character(len=*), intent(in) :: path                !! .msh/.geo file or '' (built-in bar)
        integer, intent(in) :: bar_dim                      !! bar dimension
        real(dp), intent(in) :: length                      !! bar length
        real(dp), intent(in) :: width                       !! bar width
        real(dp), intent(in) :: h                           !! bar mesh size
        type(mesh_t), intent(out) :: msh                    !! mesh
        integer, intent(out) :: stat                        !! status
        character(len=*), intent(inout), optional :: errmsg !! message
        logical, intent(in), optional :: check              !! check a file's mesh (default)
        integer, intent(in), optional :: given              !! a .geo's given parameters (bits)
        integer, intent(in), optional :: max_elements       !! > 0: refuse a .geo estimated larger
        if (len_trim(path) > 0) then
            call read_mesh_file(path, h, length, width, msh, stat, errmsg, check, given, &
                                max_elements)
        else
            call bar_mesh_build(bar_dim, length, width, h, msh, stat, errmsg)
        end if
    end subroutine mesh_load

    !> How messages name the mesh mesh_load(path, ...) gives.
    pure function mesh_label(path) result(label)
        character(len=*), intent(in) :: path   !! mesh file or ''
        character(len=:), allocatable :: label
        if (len_trim(path) > 0) then
            label = "mesh '"//trim(path)//"'"
        else
            label = 'the built-in bar'
        end if
    end function mesh_label
end module mesh_source

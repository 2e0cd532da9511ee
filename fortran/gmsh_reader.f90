!> Reader for gmsh .msh 4.1 ASCII files (nodes, segments/triangles, boundary
!> facets, physical names).
module gmsh_reader
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_BAD_INPUT, raise
    use mesh, only: mesh_t
    implicit none
    private
    public :: read_gmsh

contains

    !> Read `path` into `msh`. The mesh dimension is the highest element dimension
    !> present (1: segments, 2: triangles). Errors (STAT_BAD_INPUT, message starts
    !> with the path): missing/unreadable file, binary or non-4.1 format, missing
    !> sections, unsupported element types.
    subroutine read_gmsh(path, msh, stat, errmsg)
        character(len=*), intent(in) :: path                !! .msh file
        type(mesh_t), intent(out) :: msh                    !! mesh read
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! one-line message naming the file
        msh%dim = 0
        call raise(stat, errmsg, STAT_BAD_INPUT, trim(path)//': reader not implemented')
    end subroutine read_gmsh
end module gmsh_reader

!> The built-in bar meshes of the seed scene.
module bar_mesh
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_BAD_INPUT, raise
    use mesh, only: mesh_t
    implicit none
    private
    public :: bar_mesh_build

contains

    !> Build the bar: dim = 1 segments on [0, length] (groups bottom = {x=0},
    !> top = {x=length}, body); dim = 2 the structured triangles of GetFEM's
    !> regular simplices mesh of [0, width] x [0, length] (same nodes and diagonals
    !> as shared/reference/meshes; groups bottom, top, left, right, body).
    subroutine bar_mesh_build(dim, length, width, h, msh, stat, errmsg)
        integer, intent(in) :: dim                          !! 1 or 2
        real(dp), intent(in) :: length                      !! bar length (along x in 1D, y in 2D)
        real(dp), intent(in) :: width                       !! bar width (2D, along x)
        real(dp), intent(in) :: h                           !! mesh size (square side)
        type(mesh_t), intent(out) :: msh                    !! the mesh
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        msh%dim = dim
        call raise(stat, errmsg, STAT_BAD_INPUT, 'bar_mesh_build: not implemented')
        if (length + width + h < 0) return
    end subroutine bar_mesh_build
end module bar_mesh

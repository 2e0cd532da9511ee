!> Scene files (SPEC section 3): Fortran-namelist-format text read with a
!> tokenizer of our own, so that every error names the file, group and key.
module scene
    use kinds, only: dp
    use errors, only: STAT_OK, STAT_BAD_INPUT, raise
    implicit none
    private

    integer, parameter, public :: PATH_LEN = 1024  !! length of path strings
    integer, parameter, public :: NAME_LEN = 256   !! length of name strings

    !> A parsed scene with every default filled in (SPEC section 3).
    type, public :: scene_t
        character(len=PATH_LEN) :: path = ''              !! the scene file read ('' if built in code)
        ! &mesh
        character(len=PATH_LEN) :: mesh_file = ''         !! resolved .msh path ('' = built-in bar)
        integer :: mesh_dim = 2                           !! built-in bar dimension
        real(dp) :: mesh_length = 1.0_dp                  !! built-in bar length
        real(dp) :: mesh_width = 0.1_dp                   !! built-in bar width (2D)
        real(dp) :: mesh_h = 0.05_dp                      !! built-in bar mesh size
        ! &boundary
        character(len=NAME_LEN) :: clamped = 'top'        !! groups with u = 0
        character(len=NAME_LEN) :: slip_x = ''            !! groups with u_x = 0
        character(len=NAME_LEN) :: slip_y = ''            !! groups with u_y = 0
        character(len=NAME_LEN) :: contact = 'bottom'     !! contact boundary groups ('' = none)
        ! &material
        real(dp) :: young = 2.0_dp / 3.0_dp               !! Young's modulus E > 0
        real(dp) :: poisson = 1.0_dp / 3.0_dp             !! Poisson ratio in (-1, 1/2)
        real(dp) :: density = 1.0_dp                      !! rho > 0
        real(dp) :: gravity(2) = 0.0_dp                   !! body acceleration g (f = rho g)
        ! &contact
        character(len=NAME_LEN) :: contact_method = 'nitsche' !! only 'nitsche'
        integer :: nitsche_theta = 1                      !! -1, 0 or 1
        real(dp) :: gamma0 = 10.0_dp                      !! gamma_N = gamma0 / h_T, > 0
        real(dp) :: obstacle_point(2) = 0.0_dp            !! a point of the obstacle plane
        real(dp) :: obstacle_normal(2) = [0.0_dp, -1.0_dp] !! body's outward normal (into obstacle), normalized on read
        real(dp) :: probe(2) = [0.05_dp, 0.0_dp]          !! probe point on Gamma_C
        character(len=NAME_LEN) :: quadrature = 'exact'   !! 'exact' (facet split at the kink) or 'gauss'
        integer :: quad_points = 3                        !! Gauss points per facet for 'gauss' (1..6)
        ! &initial
        character(len=NAME_LEN) :: initial_kind = 'compressed_bar' !! 'rest' | 'velocity' | 'compressed_bar'
        real(dp) :: amplitude = 0.5_dp                    !! compressed_bar lift
        real(dp) :: velocity(2) = 0.0_dp                  !! 'velocity' initial velocity
        ! &scheme
        character(len=NAME_LEN) :: scheme_name = 'hht'    !! newmark|hht|hht_seed|theta|pc|pc_hht|pc_hht_seed
        real(dp) :: alpha = 0.0_dp                        !! HHT alpha
        real(dp) :: beta = 0.25_dp                        !! Newmark / pc beta
        real(dp) :: gamma = 0.5_dp                        !! Newmark / pc gamma
        real(dp) :: time_theta = 0.5_dp                   !! theta-scheme theta in [1/2, 1]
        real(dp) :: dt = 0.0025_dp                        !! time step > 0
        real(dp) :: t_end = 15.0_dp                       !! final time >= 0
        character(len=NAME_LEN) :: mass = 'consistent'    !! 'consistent' | 'lumped'
        real(dp) :: newton_tol = 1.0e-10_dp               !! relative residual tolerance
        integer :: newton_maxit = 50                      !! max Newton iterations > 0
        real(dp) :: blowup = 10.0_dp                      !! unstable when e_total > blowup * e_total(0)
        ! &output
        character(len=PATH_LEN) :: out_dir = 'out'        !! output folder
        integer :: every = 1                              !! trace row every this many steps
        integer :: fields_every = 0                       !! VTU snapshot every this many steps (0 = none)
    end type scene_t

    public :: scene_read, scene_to_json

contains

    !> Read and validate the scene file `path` (SPEC section 3). Groups may come in
    !> any order and each at most once; missing groups keep their defaults. A
    !> relative mesh_file is resolved against the scene file's folder. Errors give
    !> STAT_BAD_INPUT and one line "PATH: &group key: what is wrong".
    subroutine scene_read(path, scn, stat, errmsg)
        character(len=*), intent(in) :: path                !! scene file
        type(scene_t), intent(out) :: scn                   !! parsed scene
        integer, intent(out) :: stat                        !! STAT_OK or STAT_BAD_INPUT
        character(len=*), intent(inout), optional :: errmsg !! message
        scn%path = path
        call raise(stat, errmsg, STAT_BAD_INPUT, trim(path)//': scene reader not implemented')
    end subroutine scene_read

    !> The scene as a JSON object {"mesh": {...}, "boundary": {...}, ...} with the
    !> namelist key names of SPEC section 3 (contact theta is "theta" in "contact").
    function scene_to_json(scn) result(json)
        type(scene_t), intent(in) :: scn    !! scene
        character(len=:), allocatable :: json
        json = '{"path": "'//trim(scn%path)//'"}'
    end function scene_to_json
end module scene

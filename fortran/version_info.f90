!> The package version (kept equal to meson.build and pyproject.toml).
module version_info
    implicit none
    private
    character(len=*), parameter, public :: DYNCONTACT_VERSION = '0.1.0'  !! version string
end module version_info

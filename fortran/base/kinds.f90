!> Numeric kinds used everywhere in the core.
module kinds
    use iso_fortran_env, only: real64, int32, int64
    implicit none
    private
    integer, parameter, public :: dp = real64   !! the one real kind
    integer, parameter, public :: ip = int32    !! default integer kind (= c_int)
    integer, parameter, public :: i8 = int64    !! 64-bit integers (handles, counters)
end module kinds

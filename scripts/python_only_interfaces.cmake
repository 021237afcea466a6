# Included right after project() by scripts/build_interfaces.py (CMAKE_PROJECT_INCLUDE): rosidl generates only what a
# Python process on rmw_fastrtps_cpp loads. Such a process loads the C structs (rosidl_generator_c), the Python
# conversions (rosidl_generator_py), rosidl_typesupport_c and behind it rosidl_typesupport_fastrtps_c and
# rosidl_typesupport_introspection_c; never the C++ headers or the three C++ typesupports, which are most of the
# compile time. A plain CMake or colcon build of the same CMakeLists.txt (a C++ user's) still generates everything.
find_package(ament_cmake REQUIRED)
# Registers every generator on the extension point that rosidl_generate_interfaces() runs; the CMakeLists.txt's own
# find_package() of it returns at once (its Config file is included only once per project).
find_package(rosidl_default_generators REQUIRED)
set(_amr_cpp_generators
    rosidl_generator_cpp rosidl_typesupport_cpp rosidl_typesupport_introspection_cpp rosidl_typesupport_fastrtps_cpp)
foreach(_generator ${_amr_cpp_generators})
  list(FILTER AMENT_EXTENSIONS_rosidl_generate_idl_interfaces EXCLUDE REGEX "^${_generator}:")
endforeach()
message(STATUS "Python-only interfaces: not generating ${_amr_cpp_generators}")

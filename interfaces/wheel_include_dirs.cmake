# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
#
# Passed as CMAKE_PROJECT_INCLUDE when an interface package is built against the ros-jazzy-*
# wheels. Their message packages export Python targets (<pkg>__rosidl_generator_py) whose
# include directories are the wheel build machine's Python and numpy headers, which exist
# nowhere else, and CMake refuses a target that uses a missing include directory. At the end
# of the configure step, once every dependency has been found, those directories become
# this Python's.
find_package(Python3 REQUIRED COMPONENTS Interpreter Development.Module NumPy)

function(_use_this_python_for_wheel_targets)
  get_property(imported DIRECTORY "${CMAKE_SOURCE_DIR}" PROPERTY IMPORTED_TARGETS)
  foreach(target IN LISTS imported)
    if(target MATCHES "__rosidl_generator_py$")
      set_property(TARGET ${target} PROPERTY INTERFACE_INCLUDE_DIRECTORIES
        ${Python3_INCLUDE_DIRS} ${Python3_NumPy_INCLUDE_DIRS})
    endif()
  endforeach()
endfunction()

cmake_language(DEFER DIRECTORY "${CMAKE_SOURCE_DIR}" CALL _use_this_python_for_wheel_targets)

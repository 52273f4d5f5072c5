# Orocos KDL + kdl_parser as one interface target `wbm_kdl`, for tests and benchmarks only
# (never link it into the wbm library).
#
# orocos_kdl's config sets orocos_kdl_INCLUDE_DIRS / orocos_kdl_LIBRARIES (no targets).
# Debian's kdl_parser ships a catkin-generated config (kdl_parserConfig.cmake) that only
# sets kdl_parser_INCLUDE_DIRS / kdl_parser_LIBRARIES, but it find_package()s the ROS
# `urdf` package, which pulls in pluginlib and ament_cmake_core; the latter runs python3
# scripts that need the `ament_package` module and abort the configure step when python3
# on PATH is not the system one (pyenv, venv). So the library and header are located
# directly; libkdl_parser.so carries its own dependencies (urdf, rosconsole, tinyxml).
if(NOT TARGET wbm_kdl)
  find_package(orocos_kdl REQUIRED)
  find_path(WBM_KDL_PARSER_INCLUDE_DIR kdl_parser/kdl_parser.hpp REQUIRED)
  find_library(WBM_KDL_PARSER_LIBRARY kdl_parser REQUIRED)
  find_library(WBM_OROCOS_KDL_LIBRARY NAMES ${orocos_kdl_LIBRARIES} orocos-kdl REQUIRED)
  add_library(wbm_kdl INTERFACE)
  target_include_directories(wbm_kdl SYSTEM INTERFACE ${orocos_kdl_INCLUDE_DIRS} ${WBM_KDL_PARSER_INCLUDE_DIR})
  target_link_libraries(wbm_kdl INTERFACE ${WBM_KDL_PARSER_LIBRARY} ${WBM_OROCOS_KDL_LIBRARY} Eigen3::Eigen)
endif()

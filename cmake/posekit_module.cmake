# posekit_add_module(<name> SOURCES ... DEPS <posekit modules> PUBLIC_LIBS ... PRIVATE_LIBS <third-party targets>)
# Creates the library target posekit_<name> (posekit::<name>; exported and installed under that
# name) with public headers in <dir>/include.
function(posekit_add_module name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;PUBLIC_LIBS;PRIVATE_LIBS" ${ARGN})
  add_library(posekit_${name} STATIC ${ARG_SOURCES})
  add_library(posekit::${name} ALIAS posekit_${name})
  target_include_directories(posekit_${name} PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
                                                    $<BUILD_INTERFACE:${POSEKIT_GENERATED_INCLUDE_DIR}>
                                                    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  set(deps "")
  foreach(dep IN LISTS ARG_DEPS)
    list(APPEND deps posekit_${dep})
  endforeach()
  target_link_libraries(posekit_${name} PUBLIC ${deps} Eigen3::Eigen ${ARG_PUBLIC_LIBS}
                        PRIVATE ${ARG_PRIVATE_LIBS})
  set_target_properties(posekit_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON EXPORT_NAME ${name})
  install(TARGETS posekit_${name} EXPORT posekitTargets
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  set_property(GLOBAL APPEND PROPERTY POSEKIT_MODULES ${name})
  # For the per-module pkg-config files and the package's per-component dependencies.
  set_property(GLOBAL PROPERTY POSEKIT_MODULE_DEPS_${name} ${ARG_DEPS})
  set_property(GLOBAL PROPERTY POSEKIT_MODULE_PUBLIC_LIBS_${name} Eigen3::Eigen ${ARG_PUBLIC_LIBS})
  set_property(GLOBAL PROPERTY POSEKIT_MODULE_PRIVATE_LIBS_${name} ${ARG_PRIVATE_LIBS})
endfunction()

# posekit_add_test(<module> [SHARED_DATASET] SOURCES ... LIBS ...): one gtest binary per module,
# registered with CTest; SHARED_DATASET: its tests read the small dataset made once per CTest run.
function(posekit_add_test module)
  cmake_parse_arguments(ARG "SHARED_DATASET" "" "SOURCES;LIBS" ${ARGN})
  set(target posekit_${module}_tests)
  add_executable(${target} ${ARG_SOURCES})
  target_link_libraries(${target} PRIVATE posekit_${module} posekit_testing ${ARG_LIBS} GTest::gtest_main)
  add_dependencies(${target} posekit_plugins)
  set(shared "")
  if(ARG_SHARED_DATASET)
    set(shared ${POSEKIT_SHARED_DATASET_PROPERTIES})
  endif()
  gtest_discover_tests(${target} DISCOVERY_TIMEOUT 60
                       PROPERTIES ENVIRONMENT "POSEKIT_DATA=${POSEKIT_DEFAULT_DATA_ROOT}" ${shared})
endfunction()

# posekit_add_plugin(<name> SOURCES ... DEPS <posekit modules> LIBS <third-party targets>): the shared
# object libposekit_<name>_plugin.so that posekit loads on first use (posekit/core/plugin.h), built
# into <build>/lib/posekit and installed into <libdir>/posekit. It holds its own copy of the posekit
# code it calls, all hidden: only its POSEKIT_PLUGIN_EXPORT entry points are visible.
function(posekit_add_plugin name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;LIBS" ${ARGN})
  set(target posekit_${name}_plugin)
  add_library(${target} MODULE ${ARG_SOURCES} ${PROJECT_SOURCE_DIR}/modules/core/src/plugin_stamp.cpp)
  set(deps "")
  foreach(dep IN LISTS ARG_DEPS)
    list(APPEND deps posekit_${dep})
  endforeach()
  target_link_libraries(${target} PRIVATE ${deps} ${ARG_LIBS})
  target_compile_definitions(${target} PRIVATE POSEKIT_PLUGIN_STAMP="${POSEKIT_PLUGIN_STAMP}")
  set_target_properties(${target} PROPERTIES OUTPUT_NAME posekit_${name}_plugin
                        LIBRARY_OUTPUT_DIRECTORY ${POSEKIT_BUILD_PLUGIN_DIR}
                        CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON UNITY_BUILD OFF)
  target_link_options(${target} PRIVATE -Wl,--exclude-libs,ALL -Wl,-Bsymbolic)
  if(NOT POSEKIT_SANITIZE)
    target_link_options(${target} PRIVATE -Wl,--no-undefined)
  endif()
  add_dependencies(posekit_plugins ${target})
  install(TARGETS ${target} LIBRARY DESTINATION ${POSEKIT_INSTALL_PLUGIN_DIR})
endfunction()

# vim_fem from a library built elsewhere (VIM_FEM_LIBRARY): sanitizer builds of the pipeline suites
# link the uninstrumented libvim_fem.a of a normal build of the same sources instead of compiling
# fem's deal.II translation units again (ASan allows uninstrumented code in an instrumented program;
# scripts/sanitize.sh FEM_FROM, docs/robustness.md). An INTERFACE target with the usage requirements
# the built vim_fem has: its headers, vim_core and CHOLMOD after it, deal.II's definitions and library.
if(NOT EXISTS ${VIM_FEM_LIBRARY})
  message(FATAL_ERROR "VIM_FEM_LIBRARY=${VIM_FEM_LIBRARY} does not exist (build vim_fem in a normal build first)")
endif()
if(NOT DEAL_II_TARGET_CONFIG_INCLUDED)
  include(${DEAL_II_TARGET_CONFIG})
endif()
add_library(vim_fem INTERFACE)
add_library(vim::fem ALIAS vim_fem)
target_include_directories(vim_fem INTERFACE $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>)
target_compile_definitions(vim_fem INTERFACE ${DEAL_II_USER_DEFINITIONS} ${DEAL_II_USER_DEFINITIONS_RELEASE})
target_link_libraries(vim_fem INTERFACE ${VIM_FEM_LIBRARY} vim_core ${VIM_CHOLMOD_LIBRARY}
                      ${VIM_SUITESPARSECONFIG_LIBRARY} ${DEAL_II_TARGET_RELEASE})

# Install rules and the CMake package `vim_pipeline` (find_package(vim_pipeline CONFIG) gives
# vim::mesher, vim::fem, vim::pipeline), plus a pkg-config file for the mesher (Eigen + TBB only).
# Included by the top-level CMakeLists.txt after every target is defined.
#
# A library target joins the package with one line, in dependency order:
#   vim_install_library(<target> <name in the package, vim::NAME>)
# Its public headers are the .hpp/.h files under its build-tree include directories; they are
# installed into include/ and the target's include directories point there from the install tree.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(VIM_PACKAGE_NAME vim_pipeline)
set(VIM_PACKAGE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/${VIM_PACKAGE_NAME})

function(vim_install_library target export_name)
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${export_name})
  get_target_property(dirs ${target} INTERFACE_INCLUDE_DIRECTORIES)
  set(mapped "")
  foreach(dir IN LISTS dirs)
    string(FIND "${dir}" "${PROJECT_SOURCE_DIR}/" in_source)
    string(FIND "${dir}" "${PROJECT_BINARY_DIR}/" in_binary)
    if(in_source EQUAL 0 OR in_binary EQUAL 0)
      # A build-tree header folder: its headers go to include/, consumers of the install look there.
      install(DIRECTORY ${dir}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} FILES_MATCHING PATTERN "*.hpp" PATTERN "*.h")
      list(APPEND mapped "$<BUILD_INTERFACE:${dir}>")
    elseif(dir)
      list(APPEND mapped "${dir}")  # system folders and generator expressions stay as they are
    endif()
  endforeach()
  list(APPEND mapped "$<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>")
  set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${mapped}")
  install(TARGETS ${target} EXPORT ${VIM_PACKAGE_NAME}Targets
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
endfunction()

vim_install_library(vim_mesher mesher)
vim_install_library(vim_fem fem)
vim_install_library(vim_pipeline pipeline)

install(TARGETS vim-pipeline vim-make-phantom RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(FILES ${PROJECT_SOURCE_DIR}/LICENSE ${PROJECT_SOURCE_DIR}/CITATION.cff ${PROJECT_SOURCE_DIR}/CHANGELOG.md
        DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(FILES ${PROJECT_SOURCE_DIR}/examples/prostate_needle.yaml DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples)

# CMake package: the targets plus find_dependency of everything they link.
install(EXPORT ${VIM_PACKAGE_NAME}Targets NAMESPACE vim:: DESTINATION ${VIM_PACKAGE_DIR})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/vim_pipelineConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/package/${VIM_PACKAGE_NAME}Config.cmake
                              INSTALL_DESTINATION ${VIM_PACKAGE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/package/${VIM_PACKAGE_NAME}ConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/package/${VIM_PACKAGE_NAME}Config.cmake
              ${PROJECT_BINARY_DIR}/package/${VIM_PACKAGE_NAME}ConfigVersion.cmake
        DESTINATION ${VIM_PACKAGE_DIR})

# pkg-config for the mesher: -l for vim_mesher and every library target of this project it links
# (so that a core target below it is listed too), Eigen and TBB through Requires.
set(VIM_MESHER_PC_LIBS "")
set(pending vim_mesher)
while(pending)
  list(POP_FRONT pending lib)
  get_target_property(imported ${lib} IMPORTED)
  get_target_property(type ${lib} TYPE)
  if(imported OR NOT type MATCHES "LIBRARY$" OR type STREQUAL "INTERFACE_LIBRARY")
    continue()
  endif()
  get_target_property(name ${lib} OUTPUT_NAME)
  if(NOT name)
    set(name ${lib})
  endif()
  string(APPEND VIM_MESHER_PC_LIBS " -l${name}")
  get_target_property(deps ${lib} LINK_LIBRARIES)
  foreach(dep IN LISTS deps)
    if(TARGET ${dep})
      list(APPEND pending ${dep})
    endif()
  endforeach()
endwhile()
set(VIM_MESHER_PC_CFLAGS "")
if(VIM_CHECKED)
  set(VIM_MESHER_PC_CFLAGS " -DVIM_CHECKED=1")
endif()
file(RELATIVE_PATH VIM_PC_TO_PREFIX /prefix/${CMAKE_INSTALL_LIBDIR}/pkgconfig /prefix)  # relocatable
configure_file(${CMAKE_CURRENT_LIST_DIR}/vim-mesher.pc.in ${PROJECT_BINARY_DIR}/package/vim-mesher.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/package/vim-mesher.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

# Install rules and the CMake package `vim_pipeline` (find_package(vim_pipeline CONFIG) gives
# vim::mesher, vim::fem, vim::needle, vim::pipeline), plus a pkg-config file for the mesher (Eigen + TBB only).
# Included by the top-level CMakeLists.txt after every target is defined.
#
# The package holds vim_pipeline and every library target of this project it links, directly or
# not, each as vim::NAME for target vim_NAME (a new library target below the pipeline, e.g. a core
# target under the mesher, joins without a change here). Their public headers are the .hpp/.h files
# under their build-tree include directories; they are installed into include/, and the targets'
# include directories point there from the install tree.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(VIM_PACKAGE_NAME vim_pipeline)
set(VIM_PACKAGE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/${VIM_PACKAGE_NAME})

function(vim_install_library target export_name)
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${export_name})
  get_target_property(dirs ${target} INTERFACE_INCLUDE_DIRECTORIES)
  set(mapped "")
  foreach(dir IN LISTS dirs)
    set(build_dir "")
    if(dir MATCHES "^\\$<BUILD_INTERFACE:(.*)>$")
      set(build_dir "${CMAKE_MATCH_1}")
    else()
      string(FIND "${dir}" "${PROJECT_SOURCE_DIR}/" in_source)
      string(FIND "${dir}" "${PROJECT_BINARY_DIR}/" in_binary)
      if(in_source EQUAL 0 OR in_binary EQUAL 0)
        set(build_dir "${dir}")
      endif()
    endif()
    if(build_dir)
      # A build-tree header folder: its headers go to include/, consumers of the install look there.
      install(DIRECTORY ${build_dir}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} FILES_MATCHING PATTERN "*.hpp"
              PATTERN "*.h")
      list(APPEND mapped "$<BUILD_INTERFACE:${build_dir}>")
    elseif(dir AND NOT dir MATCHES "^\\$<INSTALL_INTERFACE:")
      list(APPEND mapped "${dir}")  # system folders stay as they are
    endif()
  endforeach()
  list(APPEND mapped "$<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>")
  set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${mapped}")
  install(TARGETS ${target} EXPORT ${VIM_PACKAGE_NAME}Targets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
          LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
endfunction()

# The project's (not imported) library targets that `root` links, directly or not, and `root`
# (static, shared and header-only ones).
function(vim_project_libraries root out)
  set(found "")
  set(pending ${root})
  while(pending)
    list(POP_FRONT pending lib)
    get_target_property(aliased ${lib} ALIASED_TARGET)
    if(aliased)
      set(lib ${aliased})
    endif()
    get_target_property(imported ${lib} IMPORTED)
    get_target_property(type ${lib} TYPE)
    if(imported OR NOT type MATCHES "^(STATIC|SHARED|INTERFACE)_LIBRARY$" OR lib IN_LIST found)
      continue()
    endif()
    list(APPEND found ${lib})
    get_target_property(deps ${lib} INTERFACE_LINK_LIBRARIES)
    if(NOT type STREQUAL "INTERFACE_LIBRARY")
      get_target_property(linked ${lib} LINK_LIBRARIES)
      list(APPEND deps ${linked})
    endif()
    foreach(dep IN LISTS deps)
      if(TARGET ${dep})
        list(APPEND pending ${dep})
      endif()
    endforeach()
  endwhile()
  set(${out} ${found} PARENT_SCOPE)
endfunction()

vim_project_libraries(vim_pipeline VIM_PACKAGE_LIBRARIES)
foreach(lib IN LISTS VIM_PACKAGE_LIBRARIES)
  string(REGEX REPLACE "^vim_" "" export_name ${lib})
  vim_install_library(${lib} ${export_name})
endforeach()

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
# (a core target below it is listed too), Eigen and TBB through Requires.
vim_project_libraries(vim_mesher mesher_libraries)
set(VIM_MESHER_PC_LIBS "")
foreach(lib IN LISTS mesher_libraries)
  get_target_property(type ${lib} TYPE)
  if(type STREQUAL "INTERFACE_LIBRARY")
    continue()  # headers only
  endif()
  get_target_property(name ${lib} OUTPUT_NAME)
  if(NOT name)
    set(name ${lib})
  endif()
  string(APPEND VIM_MESHER_PC_LIBS " -l${name}")
endforeach()
set(VIM_MESHER_PC_CFLAGS "")
if(VIM_CHECKED)
  set(VIM_MESHER_PC_CFLAGS " -DVIM_CHECKED=1")
endif()
file(RELATIVE_PATH VIM_PC_TO_PREFIX /prefix/${CMAKE_INSTALL_LIBDIR}/pkgconfig /prefix)  # relocatable
configure_file(${CMAKE_CURRENT_LIST_DIR}/vim-mesher.pc.in ${PROJECT_BINARY_DIR}/package/vim-mesher.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/package/vim-mesher.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

# obm_add_library(<name> [SOURCES ...] [PUBLIC_DEPS ...] [PRIVATE_DEPS ...])
#   Declares target obm_<name> with alias obm::<name>, headers in libs/<name>/include (installed),
#   warnings on, installed + exported in obmslamTargets. Header-only when no SOURCES.
function(obm_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  set(tgt obm_${name})
  if(ARG_SOURCES)
    add_library(${tgt} ${ARG_SOURCES})
    set(_scope PUBLIC)
    target_link_libraries(${tgt} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
    obm_set_warnings(${tgt})
    target_include_directories(${tgt} PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  else()
    add_library(${tgt} INTERFACE)
    set(_scope INTERFACE)
    target_link_libraries(${tgt} INTERFACE ${ARG_PUBLIC_DEPS})
  endif()
  add_library(obm::${name} ALIAS ${tgt})
  set_target_properties(${tgt} PROPERTIES EXPORT_NAME ${name} OUTPUT_NAME obm_${name})
  target_include_directories(${tgt} ${_scope}
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_compile_features(${tgt} ${_scope} cxx_std_17)
  install(TARGETS ${tgt} EXPORT obmslamTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  install(DIRECTORY include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  set_property(GLOBAL APPEND PROPERTY OBM_LIBRARY_TARGETS ${tgt})
endfunction()

function(obm_set_warnings tgt)
  target_compile_options(${tgt} PRIVATE -Wall -Wextra -Wpedantic -Wno-unused-parameter)
  if(OBM_WARNINGS_AS_ERRORS)
    target_compile_options(${tgt} PRIVATE -Werror)
  endif()
endfunction()

# obm_add_app(<name> SOURCES ... DEPS ...): an installed executable named <name>.
function(obm_add_app name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS})
  if(OBM_TCMALLOC_LIBRARY)
    # --no-as-needed: nothing references tcmalloc by name; it replaces malloc by being loaded.
    target_link_libraries(${name} PRIVATE "-Wl,--no-as-needed" ${OBM_TCMALLOC_LIBRARY} "-Wl,--as-needed")
  endif()
  obm_set_warnings(${name})
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bin)
  install(TARGETS ${name} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endfunction()

# obm_add_test(<name> SOURCES ... DEPS ... [LABELS ...]): a GoogleTest executable whose tests are
# registered one by one with ctest (gtest_discover_tests), labelled with the library name.
function(obm_add_test name)
  if(NOT OBM_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;LABELS" ${ARGN})
  if(NOT ARG_SOURCES)
    return()  # a test folder whose files are not written yet
  endif()
  add_executable(${name} ${ARG_SOURCES})
  # obm_test_common (tests/CMakeLists.txt) knows the source and build folders; no test object has
  # them compiled in, so ccache reuses it across clones and build folders.
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} obm_test_common GTest::gtest GTest::gtest_main)
  obm_set_warnings(${name})
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  include(GoogleTest)
  gtest_discover_tests(${name}
    TEST_PREFIX "${ARG_LABELS}."
    PROPERTIES LABELS "${ARG_LABELS}"
    DISCOVERY_TIMEOUT 120)
endfunction()

# obm_torch_pch(<target>): precompiles LibTorch's <torch/torch.h> once for <target> and uses it in
# those of its sources that include LibTorch (directly or through the network's torch headers);
# the others are left alone. Parsing torch.h is a quarter to a third of such a unit's compile time
# (docs/testing.md, "Build and CI").
set(OBM_TORCH_INCLUDE_REGEX
  "#include [<\"](torch/|ATen/|obm/obmnet/(model|modules|svd|losses|nmm|teacher|collectives)\\.hpp|kernels\\.hpp|untrained_model\\.hpp)")
function(obm_torch_pch tgt)
  if(NOT OBM_TORCH_PCH OR NOT TARGET ${tgt})
    return()
  endif()
  get_target_property(_srcs ${tgt} SOURCES)
  get_target_property(_dir ${tgt} SOURCE_DIR)
  set(_n 0)
  foreach(_s ${_srcs})
    if(NOT IS_ABSOLUTE ${_s})
      set(_s ${_dir}/${_s})
    endif()
    if(NOT _s MATCHES "\\.cpp$")
      continue()
    endif()
    file(STRINGS ${_s} _hits REGEX "${OBM_TORCH_INCLUDE_REGEX}")
    # A source with its own options (kernels.cpp's floating-point flags) cannot use a header
    # precompiled without them.
    get_source_file_property(_opts ${_s} DIRECTORY ${_dir} COMPILE_OPTIONS)
    if(_hits AND NOT _opts)
      math(EXPR _n "${_n} + 1")
    else()
      set_source_files_properties(${_s} DIRECTORY ${_dir} PROPERTIES SKIP_PRECOMPILE_HEADERS ON)
    endif()
  endforeach()
  # The header takes 47 s to precompile and saves each unit 6–12 s: worth it from five units on.
  if(_n GREATER_EQUAL 5)
    target_precompile_headers(${tgt} PRIVATE <torch/torch.h>)
  endif()
endfunction()

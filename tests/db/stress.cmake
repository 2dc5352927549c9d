# Concurrency and crash tests (ctest -L stress): many threads and processes on
# one store, and a subscriber killed mid-stream. store_tool is the separate
# process they spawn; it must sit next to the test binaries, where
# arscout::testing::helper_path looks for it.
add_executable(store_tool ${CMAKE_CURRENT_SOURCE_DIR}/../support/store_tool.cpp)
target_link_libraries(store_tool PRIVATE arscout_db CLI11::CLI11)

set(ARSCOUT_STRESS_TESTS concurrency_test crash_test)
foreach(name IN LISTS ARSCOUT_STRESS_TESTS)
  add_executable(${name} ${name}.cpp)
  target_link_libraries(${name} PRIVATE arscout_db arscout_test_support
                                        GTest::gtest_main)
  add_dependencies(${name} store_tool)
  set_target_properties(${name} store_tool PROPERTIES
    RUNTIME_OUTPUT_DIRECTORY "${CMAKE_CURRENT_BINARY_DIR}")
  gtest_discover_tests(${name}
    PROPERTIES FIXTURES_REQUIRED postgres ENVIRONMENT "${ARSCOUT_TEST_ENV}"
               LABELS stress TIMEOUT 180
    DISCOVERY_TIMEOUT 30)
endforeach()

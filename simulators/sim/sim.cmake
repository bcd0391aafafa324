# chromo-sim: the whole virtual lab in one process.
add_executable(chromo-sim ${CMAKE_CURRENT_LIST_DIR}/chromo_sim_main.cpp)
target_link_libraries(chromo-sim PRIVATE chromo::simulators CLI11::CLI11)

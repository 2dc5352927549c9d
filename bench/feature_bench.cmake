# feature_bench: detector/descriptor alternatives (Harris+SIFT, SIFT, ORB,
# AKAZE) for wide-baseline matching on the real images in ../shared/data;
# figures and the reading in bench/FEATURES.md. Included from
# bench/CMakeLists.txt, which runs after the top level has found CLI11 and
# Threads.
find_package(OpenCV 4 REQUIRED
             COMPONENTS core imgproc imgcodecs features2d calib3d)

# CMAKE_CURRENT_LIST_DIR (this file's folder) rather than a bare relative
# name, so the snippet also works when included from a scratch project.
add_executable(feature_bench ${CMAKE_CURRENT_LIST_DIR}/feature_bench.cpp)
# The real images are ../shared/data beside the source tree by default.
target_compile_definitions(feature_bench PRIVATE
                           ARSCOUT_SOURCE_DIR="${CMAKE_SOURCE_DIR}")
# Imported targets put OpenCV's headers on the SYSTEM include path, so
# -Wall -Wextra warnings inside them (deprecated enum arithmetic) stay quiet.
target_link_libraries(feature_bench PRIVATE
                      opencv_core opencv_imgproc opencv_imgcodecs
                      opencv_features2d opencv_calib3d
                      CLI11::CLI11 Threads::Threads)

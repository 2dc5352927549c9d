// Built in the estimators layer's include tree (engine/CMakeLists.txt):
// estimators/ sits below sfm/, so this include must not be found, and the
// engine.layering.upward_include_fails test passes only on that error.
#include "sfm/mapper.h"

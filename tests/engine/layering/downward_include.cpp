// Built in the sfm layer's include tree: sfm/ sits above estimators/ and
// scene/, so these are found (the companion of upward_include.cpp: the same
// build fails there for the order's sake, not for a broken setup).
#include "estimators/bundle_adjuster.h"
#include "scene/scene.h"
#include "sfm/mapper.h"

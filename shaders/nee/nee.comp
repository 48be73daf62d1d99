// `nee`: path tracing with next-event estimation and MIS, power heuristic (see common/path.glsl).
#version 460
#extension GL_GOOGLE_include_directive : require
#define INTEGRATOR_NEE 1
#include "common/path.glsl"

// `pt`: unidirectional path tracing with BSDF sampling only (see common/path.glsl).
#version 460
#extension GL_GOOGLE_include_directive : require
#define INTEGRATOR_NEE 0
#include "common/path.glsl"

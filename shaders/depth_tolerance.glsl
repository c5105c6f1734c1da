// The one depth tolerance of the passes that weigh neighbours by depth similarity: the bilateral
// blur (blur_bilateral.glsl) and the depth-aware upsampling (ao_upsample_common.glsl). A relative
// depth difference at which a neighbour's weight has fallen off (blur: to 1/e, upsampling: to
// 1/2). Relative, so the passes behave the same in a scene authored in millimetres or metres.
#ifndef DEPTH_TOLERANCE_GLSL
#define DEPTH_TOLERANCE_GLSL
const float DEPTH_TOLERANCE = 0.05;
#endif

// Interpolation of one joint's rotation given as an exponential map (3 values,
// radians), on the sphere of unit quaternions: what resampling a take and
// crossfading its windows do to every joint, instead of a per-component lerp
// of the exponential maps (which leaves the shortest arc whenever the axis
// turns, and fails outright across the pi boundary).
//
// Reentrant: a pure function of its arguments.
#pragma once

namespace mm {

// The rotation a fraction t (0..1) of the way from a to b along the shortest
// arc (quaternion slerp), written to out[0..2] as an exponential map. A
// rotation has many exponential maps (the angle plus any multiple of 2 pi,
// or the axis flipped); the one nearest the per-component lerp of a and b is
// written, so that a motion whose maps cross pi keeps its own
// representation from frame to frame. t == 0 writes a and t == 1 writes b
// exactly. A NaN in a (or b) makes the result NaN unless its weight is 0
// (t == 1, or t == 0): a missing rotation stays missing.
// `out` may alias a or b.
void slerp_expmap(const float* a, const float* b, double t, float* out);

// The exponential map of the unit quaternion (w, x, y, z) nearest
// `reference` (3 values) among its maps (the angle plus any multiple of 2 pi
// along the axis), written to out[0..2], so that a joint's maps stay
// continuous from frame to frame; the identity keeps the reference's axis.
void write_expmap_nearest(double w, double x, double y, double z, const double* reference, float* out);

}  // namespace mm

#include "format/expmap_slerp.h"

#include <cmath>

namespace mm {
namespace {

struct Quaternion {
  double w, x, y, z;
};

// exp(v / 2) for an exponential map v: the unit quaternion of the rotation
// by |v| about v / |v|. sin(t/2)/t by its series near 0, where it is 1/2.
Quaternion quaternion_of(const float* v) {
  const double x = v[0], y = v[1], z = v[2];
  const double angle = std::sqrt(x * x + y * y + z * z);
  const double half_sinc = angle < 1e-6 ? 0.5 - angle * angle / 48.0 : std::sin(angle / 2) / angle;
  return {std::cos(angle / 2), x * half_sinc, y * half_sinc, z * half_sinc};
}

}  // namespace

void write_expmap_nearest(double w, double x, double y, double z, const double* reference, float* out) {
  // Axis and angle, the angle in [0, 2 pi).
  const double vector_norm = std::sqrt(x * x + y * y + z * z);
  if (vector_norm < 1e-12) {
    // The identity: its maps are 2 pi k times any axis; keep the
    // reference's axis so that a map near 2 pi stays near it.
    const double reference_norm =
        std::sqrt(reference[0] * reference[0] + reference[1] * reference[1] + reference[2] * reference[2]);
    const double turns = std::round(reference_norm / (2 * M_PI));
    for (int i = 0; i < 3; ++i) {
      out[i] = reference_norm > 0 ? static_cast<float>(reference[i] / reference_norm * turns * 2 * M_PI) : 0.0f;
    }
    return;
  }
  const double axis[3] = {x / vector_norm, y / vector_norm, z / vector_norm};
  const double angle = 2 * std::atan2(vector_norm, w);
  // Of the maps (angle + 2 pi k) axis, the one nearest the reference.
  const double along = axis[0] * reference[0] + axis[1] * reference[1] + axis[2] * reference[2];
  const double chosen = angle + 2 * M_PI * std::round((along - angle) / (2 * M_PI));
  for (int i = 0; i < 3; ++i) out[i] = static_cast<float>(axis[i] * chosen);
}

void slerp_expmap(const float* a, const float* b, double t, float* out) {
  if (t == 0) {
    for (int i = 0; i < 3; ++i) out[i] = a[i];
    return;
  }
  if (t == 1) {
    for (int i = 0; i < 3; ++i) out[i] = b[i];
    return;
  }
  // Computed before `out` is written: it may alias a or b.
  double reference[3];
  for (int i = 0; i < 3; ++i) reference[i] = (1 - t) * a[i] + t * b[i];
  if (!std::isfinite(reference[0]) || !std::isfinite(reference[1]) || !std::isfinite(reference[2])) {
    for (int i = 0; i < 3; ++i) out[i] = NAN;
    return;
  }
  const Quaternion p = quaternion_of(a);
  Quaternion q = quaternion_of(b);
  double cosine = p.w * q.w + p.x * q.x + p.y * q.y + p.z * q.z;
  // q and -q are one rotation: take the one on the shorter arc from p.
  if (cosine < 0) {
    q = {-q.w, -q.x, -q.y, -q.z};
    cosine = -cosine;
  }
  double wp = 1 - t, wq = t;
  if (cosine < 1 - 1e-10) {
    const double theta = std::acos(std::fmin(cosine, 1.0));
    const double sine = std::sin(theta);
    wp = std::sin((1 - t) * theta) / sine;
    wq = std::sin(t * theta) / sine;
  }
  Quaternion r{wp * p.w + wq * q.w, wp * p.x + wq * q.x, wp * p.y + wq * q.y, wp * p.z + wq * q.z};
  const double norm = std::sqrt(r.w * r.w + r.x * r.x + r.y * r.y + r.z * r.z);
  r = {r.w / norm, r.x / norm, r.y / norm, r.z / norm};
  write_expmap_nearest(r.w, r.x, r.y, r.z, reference, out);
}

}  // namespace mm

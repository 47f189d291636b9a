#include "format/rotation_matrix.h"

#include <algorithm>
#include <cctype>
#include <cmath>

namespace mm {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegrees = 180.0 / kPi;

}  // namespace

Mat3 identity_matrix() { return Mat3{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}}; }

Mat3 multiply(const Mat3& a, const Mat3& b) {
  Mat3 r{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
  return r;
}

Mat3 transpose(const Mat3& m) {
  Mat3 r{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r[i][j] = m[j][i];
  return r;
}

Vec3 multiply(const Mat3& m, const Vec3& v) {
  return {m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2], m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
          m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2]};
}

Vec3 multiply(const Vec3& v, const Mat3& m) { return multiply(transpose(m), v); }

Mat3 expmap_to_matrix(const Vec3& e) {
  const double theta2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
  double a, b;  // sin(t)/t and (1-cos t)/t^2
  if (theta2 < 1e-12) {
    a = 1.0 - theta2 / 6.0;
    b = 0.5 - theta2 / 24.0;
  } else {
    const double theta = std::sqrt(theta2);
    a = std::sin(theta) / theta;
    b = (1.0 - std::cos(theta)) / theta2;
  }
  const Mat3 k{{{0, -e[2], e[1]}, {e[2], 0, -e[0]}, {-e[1], e[0], 0}}};
  const Mat3 k2 = multiply(k, k);
  Mat3 r = identity_matrix();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r[i][j] += a * k[i][j] + b * k2[i][j];
  return r;
}

Vec3 matrix_to_expmap(const Mat3& m) {
  // Shepperd's method: the largest of w, x, y, z is computed from the
  // diagonal, where it cannot lose precision, the others from off-diagonals.
  const double trace = m[0][0] + m[1][1] + m[2][2];
  double w, x, y, z;
  if (trace >= m[0][0] && trace >= m[1][1] && trace >= m[2][2]) {
    const double s = 2.0 * std::sqrt(std::max(0.0, 1.0 + trace));
    w = 0.25 * s;
    x = (m[2][1] - m[1][2]) / s;
    y = (m[0][2] - m[2][0]) / s;
    z = (m[1][0] - m[0][1]) / s;
  } else if (m[0][0] >= m[1][1] && m[0][0] >= m[2][2]) {
    const double s = 2.0 * std::sqrt(std::max(0.0, 1.0 + m[0][0] - m[1][1] - m[2][2]));
    w = (m[2][1] - m[1][2]) / s;
    x = 0.25 * s;
    y = (m[0][1] + m[1][0]) / s;
    z = (m[0][2] + m[2][0]) / s;
  } else if (m[1][1] >= m[2][2]) {
    const double s = 2.0 * std::sqrt(std::max(0.0, 1.0 + m[1][1] - m[0][0] - m[2][2]));
    w = (m[0][2] - m[2][0]) / s;
    x = (m[0][1] + m[1][0]) / s;
    y = 0.25 * s;
    z = (m[1][2] + m[2][1]) / s;
  } else {
    const double s = 2.0 * std::sqrt(std::max(0.0, 1.0 + m[2][2] - m[0][0] - m[1][1]));
    w = (m[1][0] - m[0][1]) / s;
    x = (m[0][2] + m[2][0]) / s;
    y = (m[1][2] + m[2][1]) / s;
    z = 0.25 * s;
  }
  if (w < 0) {  // the same rotation; keeps the angle in [0, pi]
    w = -w, x = -x, y = -y, z = -z;
  }
  const double sin_half = std::sqrt(x * x + y * y + z * z);
  if (sin_half < 1e-300) return {0, 0, 0};
  const double angle = 2.0 * std::atan2(sin_half, w);
  const double scale = angle / sin_half;
  return {x * scale, y * scale, z * scale};
}

Mat3 axis_rotation(int axis, double radians) {
  const double c = std::cos(radians), s = std::sin(radians);
  switch (axis) {
    case 0:
      return Mat3{{{1, 0, 0}, {0, c, -s}, {0, s, c}}};
    case 1:
      return Mat3{{{c, 0, s}, {0, 1, 0}, {-s, 0, c}}};
    default:
      return Mat3{{{c, -s, 0}, {s, c, 0}, {0, 0, 1}}};
  }
}

bool EulerOrder::parse(const std::string& text, EulerOrder* order) {
  if (text.size() != 3) return false;
  EulerOrder result;
  bool seen[3] = {false, false, false};
  for (int i = 0; i < 3; ++i) {
    const char c = static_cast<char>(std::toupper(static_cast<unsigned char>(text[i])));
    if (c < 'X' || c > 'Z' || seen[c - 'X']) return false;
    seen[c - 'X'] = true;
    result.axes[i] = c - 'X';
  }
  *order = result;
  return true;
}

std::string EulerOrder::name() const {
  return std::string{static_cast<char>('X' + axes[0]), static_cast<char>('X' + axes[1]),
                     static_cast<char>('X' + axes[2])};
}

Mat3 euler_degrees_to_matrix(const EulerOrder& order, const Vec3& degrees) {
  Mat3 r = axis_rotation(order.axes[0], degrees[0] / kDegrees);
  r = multiply(r, axis_rotation(order.axes[1], degrees[1] / kDegrees));
  return multiply(r, axis_rotation(order.axes[2], degrees[2] / kDegrees));
}

Vec3 matrix_to_euler_degrees(const EulerOrder& order, const Mat3& m) {
  const int i = order.axes[0], j = order.axes[1], k = order.axes[2];
  // +1 for the cyclic orders (XYZ, YZX, ZXY), -1 for the others: the sign
  // with which sin(middle angle) appears at m[i][k].
  const double s = ((j - i + 3) % 3 == 1) ? 1.0 : -1.0;
  const double cos_b = std::hypot(m[i][i], m[i][j]);
  const double b = std::atan2(s * m[i][k], cos_b);
  double a, c;
  if (cos_b > 1e-12) {
    a = std::atan2(-s * m[j][k], m[k][k]);
    c = std::atan2(-s * m[i][j], m[i][i]);
  } else {
    // Gimbal lock: only a +- c is defined; with c = 0 the middle rotation
    // keeps axis j, so column j of m is R_i(a) e_j.
    c = 0.0;
    a = std::atan2(s * m[k][j], m[j][j]);
  }
  return {a * kDegrees, b * kDegrees, c * kDegrees};
}

}  // namespace mm

# Writes pair_000K_{src,tgt}.ply and gt.txt: a bumpy sheet with a wall and a post (no symmetry),
# target = R·source + t with a known small motion per pair.
function ply(file, n) { print "ply\nformat ascii 1.0\nelement vertex " n "\nproperty float x\nproperty float y\nproperty float z\nend_header" > file }
BEGIN {
  srand(7); n = 1024; pi = 3.14159265358979
  for (i = 0; i < n; ++i) {
    u = rand(); v = rand(); w = rand()
    if (i < 640) { x[i] = -0.6 + 1.2 * u; y[i] = -0.6 + 1.2 * v; z[i] = 0.15 * sin(3 * x[i]) * cos(2 * y[i]) }
    else if (i < 896) { x[i] = -0.6; y[i] = -0.6 + 0.9 * u; z[i] = 0.5 * v }
    else { a = 2 * pi * u; x[i] = 0.35 + 0.08 * cos(a); y[i] = 0.2 + 0.08 * sin(a); z[i] = 0.6 * v }
  }
  for (p = 0; p < 2; ++p) {
    yaw = (8 + 6 * p) * pi / 180; roll = (3 + 2 * p) * pi / 180
    cz = cos(yaw); sz = sin(yaw); cx = cos(roll); sx = sin(roll)
    # R = Rz(yaw)·Rx(roll)
    r11 = cz; r12 = -sz * cx; r13 = sz * sx
    r21 = sz; r22 = cz * cx;  r23 = -cz * sx
    r31 = 0;  r32 = sx;       r33 = cx
    tx = 0.05 - 0.02 * p; ty = -0.03; tz = 0.02 + 0.01 * p
    id = sprintf("%04d", p); src = dir "/pair_" id "_src.ply"; tgt = dir "/pair_" id "_tgt.ply"
    ply(src, n); ply(tgt, n)
    for (i = 0; i < n; ++i) {
      print x[i], y[i], z[i] > src
      print r11*x[i] + r12*y[i] + r13*z[i] + tx, r21*x[i] + r22*y[i] + r23*z[i] + ty, r31*x[i] + r32*y[i] + r33*z[i] + tz > tgt
    }
    close(src); close(tgt)
    printf "%s %.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", id, r11, r12, r13, tx, r21, r22, r23, ty, r31, r32, r33, tz > (dir "/gt.txt")
  }
}

#!/usr/bin/env python3
"""A hall of N boxes standing on its floor, as an lrr scene description (docs/MESHING.md).

    python3 scripts/boxes-hall.py N SIDE OUT.toml

The floor is SIDE x SIDE, the hall SIDE/8 high (closed, inward), a square lamp of SIDE/5 under
its ceiling; the boxes (one indexed mesh of quads, surface "boxes") stand one in each cell of a
sqrt(N) x sqrt(N) lattice, 0.2-0.6 of a cell wide, 0.2-1 of a cell high, shifted at random
(seed 7): the same file every time.
"""
import random, sys
n = int(sys.argv[1]); side = float(sys.argv[2]); out = sys.argv[3]
random.seed(7)
verts = []; faces = []
g = int(n ** 0.5 + 0.999)
cell = side / g
k = 0
for i in range(g):
    for j in range(g):
        if k == n: break
        k += 1
        s = cell * random.uniform(0.2, 0.6); h = cell * random.uniform(0.2, 1.0)
        cx = -side / 2 + (i + 0.5) * cell + random.uniform(-0.15, 0.15) * cell
        cy = -side / 2 + (j + 0.5) * cell + random.uniform(-0.15, 0.15) * cell
        x0, x1, y0, y1, z0, z1 = cx - s / 2, cx + s / 2, cy - s / 2, cy + s / 2, 0.0, h
        b = len(verts)
        for z in (z0, z1):
            for (x, y) in ((x0, y0), (x1, y0), (x1, y1), (x0, y1)):
                verts.append((x, y, z))
        # outward CCW quads
        q = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
        for f in q: faces.append([b + v for v in f])
L = side / 2
with open(out, 'w') as f:
    f.write('name = "boxes"\n')
    f.write('[[material]]\nname = "grey"\nreflectance = [0.6, 0.6, 0.6]\n')
    f.write('[[material]]\nname = "lamp"\nreflectance = [0.0, 0.0, 0.0]\nradiance = [5.0, 5.0, 5.0]\n')
    f.write('[[box]]\nname = "hall"\nmaterial = "grey"\nmin = [%g, %g, 0]\nmax = [%g, %g, %g]\ninward = true\n' % (-L, -L, L, L, side / 8))
    c = side / 8 - 0.01
    f.write('[[surface]]\nname = "lamp"\nmaterial = "lamp"\npolygons = [[[%g, %g, %g], [%g, %g, %g], [%g, %g, %g], [%g, %g, %g]]]\n' % (-side/10, -side/10, c, -side/10, side/10, c, side/10, side/10, c, side/10, -side/10, c))
    f.write('[[surface]]\nname = "boxes"\nmaterial = "grey"\nvertices = [%s]\n' % ', '.join('[%.4f, %.4f, %.4f]' % v for v in verts))
    f.write('faces = [%s]\n' % ', '.join('[%s]' % ', '.join(map(str, fc)) for fc in faces))

# The engine comparison scene, Yade side: 2,000 spheres (radius 4 mm) dropped into a
# 0.2 x 0.1 m box under gravity, linear contacts (E = 2 MPa, friction 0.5), 5,000 steps of 1e-4 s.
# compare_liggghts.in is the same scene for LIGGGHTS. Run: yade -n -x compare_yade.py
import time
from yade import pack

N_STEPS = 5000
O.materials.append(FrictMat(young=2e6, poisson=0.3, frictionAngle=atan(0.5), density=2500))
O.bodies.append(aabbWalls([(0, 0, 0), (0.2, 0.1, 0.3)], thickness=0.01, oversizeFactor=1.0))
# A simple-cubic lattice of 9 mm spacing, as LIGGGHTS' create_atoms makes it.
n = 0
for k in range(40):
    for j in range(10):
        for i in range(21):
            if n == 2000:
                break
            O.bodies.append(sphere((0.0055 + 0.009 * i, 0.0055 + 0.009 * j, 0.0055 + 0.009 * k), 0.004))
            n += 1
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Box_Aabb()], verletDist=0.002),
    InteractionLoop(
        [Ig2_Sphere_Sphere_ScGeom(), Ig2_Box_Sphere_ScGeom()],
        [Ip2_FrictMat_FrictMat_FrictPhys()],
        [Law2_ScGeom_FrictPhys_CundallStrack()],
    ),
    NewtonIntegrator(gravity=(0, 0, -9.81), damping=0.2),
]
O.dt = 1e-4
start = time.time()
O.run(N_STEPS, True)
wall = time.time() - start
spheres = sum(1 for b in O.bodies if isinstance(b.shape, Sphere))
print("yade spheres=%d steps=%d wall_s=%.2f particle_steps_per_s=%.0f" % (spheres, N_STEPS, wall, spheres * N_STEPS / wall))

"""PyBullet simulation of a bimanual Franka Panda: world, objects, skill executors, rendering."""

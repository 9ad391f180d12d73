"""What the world model holds and how a component reaches it: objects, shapes, clients."""

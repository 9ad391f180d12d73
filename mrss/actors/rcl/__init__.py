"""The Robot Communication Layer (paper IV-E): actions refined into skills on robot actors.

The action lifecycle and its journal, robot and skill actors, resources, the availability of
robots, and the base classes a project subclasses (RobotCommLayer, Skill, Action)."""

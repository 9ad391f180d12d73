"""The Reasoner (paper IV-D): the project's AgentSpeak agent, percepts in, actions out."""

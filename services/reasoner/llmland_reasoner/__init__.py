"""LLM-Land reasoner: caption -> knowledge-base retrieval -> small LLM -> SafetySpec."""

from .kb import KbEntry, KnowledgeBase

__all__ = ["KbEntry", "KnowledgeBase"]

"""The paper's procedures as scripts, the campaign runner and run storage."""

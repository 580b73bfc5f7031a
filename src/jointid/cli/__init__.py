"""jointid.cli"""

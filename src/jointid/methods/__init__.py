"""jointid.methods"""

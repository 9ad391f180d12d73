"""Components of MRSS and the pykka actors inside them."""
